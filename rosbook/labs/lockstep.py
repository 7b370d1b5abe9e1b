"""What the judges of several labs share to watch a student's node in the kernel.

The student's node runs in the kernel; the judge's nodes listen to it, wait until the
two sides have discovered each other (each side discovers on its own: a message sent
before is lost, not late), and move its simulated time in lockstep: the judge publishes
``/clock``, the kernel's agent (``rosbook.labs.agent.JudgeAgent.follow_clock``) runs the
node's due callbacks and acknowledges how far it came, and the judge waits for what the
node sent to arrive before time moves on (``published_on_sim_time``, ``RemoteClock``).
Every wait is for an event; a hang guard says "timeout" (``JudgeTimeout``), never wrong.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from rclpy.context import Context
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.node import Node
from std_msgs.msg import String

from rosbook.labs.agent import ACK_TOPIC
from rosbook.labs.probes import CheckFailed, assert_endpoint
from rosbook.labs.remote import (
    EVENT_GUARD_S,
    KERNEL_REPLY_GUARD_S,
    Judgement,
    JudgeTimeout,
    KernelError,
    clock_message,
    clock_publisher,
    drain,
    ros_node,
)
from rosbook.runtime.callbacks import Callbacks, WakingExecutor
from rosbook.runtime.session import ros

#: Wall-clock seconds after which an unanswered /clock step is published again.
CLOCK_RETRY_S = 0.2
#: Simulated time step of the checks' clocks: every period they use is a multiple of it.
SIM_STEP_S = 0.05


def require_endpoint(info: dict[str, Any], topic: str, msg_type: type, kind: str) -> None:
    """Fail fast, with the lab's message, when the node says it lacks the endpoint (what
    it says only shortens a failure: a pass needs the traffic)."""
    assert_endpoint(info["name"], info[kind + "s"], topic, msg_type, kind)


def require_name(info: dict[str, Any], call: str, expected: str) -> None:
    if info["name"] != expected:
        raise CheckFailed(f"{call} made a node named {info['name']!r}, expected {expected!r}")


def wait_for(
    condition: Callable[[], bool], *nodes: Node, what: str, guard: float = EVENT_GUARD_S
) -> None:
    if not ros.spin_until(condition, *nodes, timeout=guard):
        raise JudgeTimeout(f"{what} after {guard:.0f} s")


class Listener:
    """A subscription of the judge's own (in ``context``, default the session's);
    ``data`` in arrival order."""

    def __init__(
        self, topic: str, msg_type: type, qos: Any = 10, context: Context | None = None
    ) -> None:
        # one name per context: rcl's /rosout publishers are the process's, by node name
        name = "judge_listener_" + topic.strip("/") + ("" if context is None else "_own")
        self.node = ros_node(name, context)
        self.data: list[Any] = []
        self.sub = self.node.create_subscription(
            msg_type, topic, lambda m: self.data.append(m.data), qos
        )

    def drain(self) -> None:
        """Take what has arrived, without waiting for more."""
        drain(self.node)


def published_on_sim_time(
    j: Judgement, name: str, topic: str, msg_type: type, seconds: float, step: float = 0.05
) -> tuple[list[Any], list[float]]:
    """Run the kernel's node through ``seconds`` of the judge's ``/clock``, in lockstep:
    after each time step the kernel says (on ``ACK_TOPIC``) that the node ran
    its due callbacks and how many messages it published; the judge waits for them to
    arrive before it publishes the next time. Returns (data, simulated arrival times).
    The kernel's word only paces the judge: what is judged is what arrives."""
    listener = Listener(topic, msg_type)
    clock = clock_publisher(listener.node)
    acked: list[dict[str, Any]] = [read_ack("")]
    acks = listener.node.create_subscription(
        String, ACK_TOPIC, lambda m: acked.append(read_ack(m.data)), 10
    )
    wait_for(
        lambda: listener.sub.get_publisher_count() > 0 and clock.get_subscription_count() > 0,
        listener.node,
        what=f"node '{name}' and the judge did not connect on {topic} and /clock",
    )
    following = j.kernel.send("follow_clock", seconds, EVENT_GUARD_S)
    wait_for(
        lambda: acks.get_publisher_count() > 0,
        listener.node,
        what=f"node '{name}' did not start on /clock",
    )
    wait_until_discovered(acked, listener.node, topic, listener.node.get_name(), name)
    times: list[float] = []
    t = 0.0
    while t < seconds - 1e-9:
        t = min(t + step, seconds)
        before = len(listener.data)
        target = int(round(t * 1e9))
        deadline = time.monotonic() + EVENT_GUARD_S
        # a /clock message to a best-effort subscription can be lost: sent again until acked
        while True:
            clock.publish(clock_message(t))
            if ros.spin_until(
                lambda target=target: acked[-1]["now"] >= target,
                listener.node,
                timeout=CLOCK_RETRY_S,
            ):
                break
            if time.monotonic() > deadline:
                raise JudgeTimeout(f"node '{name}' did not follow /clock to t = {t:.2f} s")
        sent = acked[-1]["published"].get(topic, 0)
        ros.spin_until(
            lambda sent=sent: len(listener.data) >= sent, listener.node, timeout=EVENT_GUARD_S
        )
        times += [t] * (len(listener.data) - before)
    if j.kernel.answer(following)["timeout"]:
        raise JudgeTimeout(f"node '{name}' stopped following /clock")
    return listener.data, times


def read_ack(text: str) -> dict[str, Any]:
    try:
        ack = json.loads(text)
        return {
            "now": int(ack["now"]),
            "published": dict(ack["published"]),
            "feedback_at": [int(t) for t in ack.get("feedback_at", [])],
            "taken": dict(ack.get("taken", {})),
            "readers": {str(k): set(v) for k, v in dict(ack.get("readers", {})).items()},
            "raised": bool(ack.get("raised", False)),
        }
    except (ValueError, KeyError, TypeError):
        return {
            "now": -1, "published": {}, "feedback_at": [], "taken": {}, "readers": {},
            "raised": False,
        }  # fmt: skip


def wait_until_discovered(
    acked: list[dict[str, Any]], node: Node, topic: str, reader: str, name: str
) -> None:
    """Wait until the kernel's node ``name`` says (in its acks) that it discovered every
    subscription of the judge's node ``reader`` on ``topic``. Its publisher sends only to
    the subscriptions it knows: what it sent before would be lost, not late. (The judge's
    side matching says nothing of that: discovery runs on each side on its own.)"""

    def discovered() -> bool:
        mine = {
            bytes(e.endpoint_gid).hex()
            for e in node.get_subscriptions_info_by_topic(topic)
            if e.node_name == reader
        }
        return bool(mine) and mine <= acked[-1]["readers"].get(topic, set())

    wait_for(
        discovered,
        node,
        what=f"node '{name}' did not discover the judge's subscription on {topic}",
        guard=3 * EVENT_GUARD_S,
    )


def await_discovered_by(j: Judgement, sender: Node, topic: str, name: str) -> None:
    """Wait until the kernel's node ``name`` has discovered every publisher of the judge's
    node ``sender`` on ``topic``. Its subscription takes nothing from a publisher it does
    not know: the first value sent before was lost, not late (seen: a right subscriber
    of lab 1 missed the 7 of [7, -2, ...] on a busy machine). The judge's side matching
    says nothing of that (discovery runs on each side on its own)."""
    mine = [
        bytes(e.endpoint_gid).hex()
        for e in sender.get_publishers_info_by_topic(topic)
        if e.node_name == sender.get_name()
    ]
    guard = 3 * EVENT_GUARD_S
    if not j.kernel.call("await_writers", topic, mine, guard, guard=guard + KERNEL_REPLY_GUARD_S):
        raise JudgeTimeout(
            f"node '{name}' did not discover the judge's publisher on {topic} after {guard:.0f} s"
        )


#: Hang guard of each lockstep wait (discovery of the judge's nodes, a step's ack, its
#: messages' arrival): generous, a loaded machine takes seconds to discover a node.
LOCKSTEP_GUARD_S = 3 * EVENT_GUARD_S


#: Wall-clock guard of the agent's following /clock while the judge holds a time (it
#: calls services and sets parameters meanwhile).
HOLD_GUARD_S = 120.0


class NodeRaised(Exception):
    """The kernel said a callback of the followed node raised (``RemoteClock``)."""


class RemoteClock:
    """``/clock`` of the judge's, followed in lockstep by the student's node in the kernel
    (``JudgeAgent.follow_clock``), with the ``now`` / ``advance`` of a ``SimClock``.

    After each step the kernel says its node ran the due callbacks and how many messages
    it published (``published``: by topic, and action feedback under "feedback"); the
    judge's ``arrived(published)`` must then hold before time moves on, so each message
    is stamped with the time it was sent at. While the judge holds a time, the kernel
    goes on spinning the node: its services, actions and parameters answer.
    """

    def __init__(self, j: Judgement, name: str, gate: str | None = None) -> None:
        self.kernel, self.name, self.gate = j.kernel, name, gate
        self.node = ros_node("judge_clock")
        self.clock = clock_publisher(self.node)
        self.acked: list[dict[str, Any]] = [read_ack("")]
        self.acks = self.node.create_subscription(
            String,
            ACK_TOPIC,
            self._on_ack,
            10,
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False),
        )
        # the lockstep's waits on this node alone: rcl's wait on a kept wait set
        self.callbacks = Callbacks([self.node], WakingExecutor())
        self.arrived: Callable[[dict[str, int]], bool] = lambda published: True
        self.t = 0.0
        # the student's node's own subscription (the judge's nodes on sim time have theirs)
        wait_for(
            lambda: any(
                e.node_name == name for e in self.node.get_subscriptions_info_by_topic("/clock")
            ),
            self.node,
            what=f"node '{name}' does not listen to /clock",
            guard=LOCKSTEP_GUARD_S,
        )
        self.following = self.kernel.send("follow_clock", FOREVER_S, HOLD_GUARD_S, gate)
        try:
            wait_for(
                lambda: self.acks.get_publisher_count() > 0 and self.acked[-1]["now"] >= 0,
                self.node,
                what=f"node '{name}' did not start on /clock",
                guard=LOCKSTEP_GUARD_S,
            )
        except NodeRaised:  # at its first time: the kernel's error (a KernelError) says why
            self.kernel.answer(self.following, HOLD_GUARD_S)
            raise

    def _on_ack(self, msg: String) -> None:
        self.acked.append(read_ack(msg.data))
        if self.acked[-1]["raised"]:
            # Whatever spins the judge's nodes now (a service call, a wait) stops here:
            # the node will not answer. ``finish`` then reads the error.
            raise NodeRaised(f"a callback of node '{self.name}' raised")

    @property
    def now(self) -> float:
        return self.t

    def advance(self, seconds: float, *nodes: Node, step: float = SIM_STEP_S) -> None:
        """Move ``/clock`` on by ``seconds``, in lockstep; the judge's ``nodes`` (default:
        all of its own) spin meanwhile."""
        end = self.t + seconds
        while self.t < end - 1e-9:
            self.t = min(self.t + step, end)
            self._hold(self.t, nodes)

    def wait_for(self, condition: Callable[[], bool], *, what: str, guard: float) -> None:
        """Spin the clock's node until ``condition()`` (raises ``JudgeTimeout`` after
        ``guard`` s, saying ``what`` did not happen)."""
        if not self.callbacks.spin_until(condition, guard):
            raise JudgeTimeout(f"{what} after {guard:.0f} s")

    def _spin_until(
        self, condition: Callable[[], bool], nodes: tuple[Node, ...], timeout: float
    ) -> bool:
        """Spin the judge's ``nodes`` (all of them if none) and the clock's node until
        ``condition()``; whether it came true within ``timeout`` s."""
        if nodes == (self.node,):
            return self.callbacks.spin_until(condition, timeout)
        watched = (*nodes, self.node) if nodes else ()
        return ros.spin_until(condition, *watched, timeout=timeout)

    def _hold(self, t: float, nodes: tuple[Node, ...]) -> None:
        target = int(round(t * 1e9))
        deadline = time.monotonic() + LOCKSTEP_GUARD_S
        # With a gate the reading sent for time t carries it (the kernel's node takes it,
        # then reads t): /clock only if no ack comes. A /clock message to a best-effort
        # subscription can be lost: sent again until acked.
        send = self.gate is None
        while True:
            if send:
                self.clock.publish(clock_message(t))
            send = True
            if self._spin_until(lambda: self.acked[-1]["now"] >= target, nodes, CLOCK_RETRY_S):
                break
            if time.monotonic() > deadline:
                waited = f" (nor took {self.gate} stamped then)" if self.gate else ""
                raise JudgeTimeout(
                    f"node '{self.name}' did not follow /clock to t = {t:g} s{waited}"
                )
        published = self.acked[-1]["published"]
        if not self._spin_until(lambda: self.arrived(published), nodes, LOCKSTEP_GUARD_S):
            raise JudgeTimeout(
                f"what node '{self.name}' sent at t = {t:g} s ({published}) did not arrive"
            )

    def finish(self) -> None:
        """Let the kernel's following end; a callback's exception there comes out as a
        ``KernelError``."""
        end = FOREVER_S
        if not ros.owns(self.node):  # a fresh ros.sim_clock() of the judge's reset it
            self.callbacks.executor.shutdown(timeout_sec=0)
            self.node = ros_node("judge_clock")
            self.clock = clock_publisher(self.node)
            self.callbacks = Callbacks([self.node], WakingExecutor())
        self.clock.publish(clock_message(end))
        answered: list[Any] = []
        stopper = threading.Event()

        def keep_publishing() -> None:  # the last /clock can be lost too
            while not stopper.wait(CLOCK_RETRY_S):
                self.clock.publish(clock_message(end))

        thread = threading.Thread(target=keep_publishing, daemon=True)
        thread.start()
        try:
            answered.append(self.kernel.answer(self.following, HOLD_GUARD_S))
        finally:
            stopper.set()
            thread.join()
            self.callbacks.executor.shutdown(timeout_sec=0)
            ros.remove(self.node)
        if answered[0]["timeout"]:
            raise JudgeTimeout(f"node '{self.name}' stopped following /clock")


#: The time the judge's clock ends at: after every time a check holds.
FOREVER_S = 1e6


@contextmanager
def remote_clock(j: Judgement, name: str, gate: str | None = None) -> Iterator[RemoteClock]:
    """A ``RemoteClock`` for node ``name`` for the time of the block (with ``gate``, a
    time moves on in the kernel once the node took a message on that topic stamped with
    it: ``JudgeAgent.follow_clock``). The kernel's following always ends with it; an exception
    the node's callbacks raised there comes out as a ``KernelError``, which wins over what
    the judge saw of it (it says why)."""
    clock = RemoteClock(j, name, gate)
    try:
        yield clock
    except BaseException:
        try:
            clock.finish()
        except KernelError:
            raise
        except Exception:  # noqa: S110 - what the block raised says more
            pass
        raise
    clock.finish()


class RemoteNode:
    """The name of a node in the kernel, for checks that reach it from outside."""

    def __init__(self, name: str) -> None:
        self.name = name

    def get_name(self) -> str:
        return self.name

    def get_fully_qualified_name(self) -> str:
        return "/" + self.name
