"""Lab 3's checks as the judge runs them: verdicts from service calls and what they return.

The student's nodes run in the kernel, following the judge's ``/clock`` in lockstep
(``RemoteClock``); the judge calls their service, sends goals to their action, sets their
parameters and listens to their topic from nodes of its own, so every answer is the
judge's to read. One thing is the kernel's word: the simulated time at which each action
feedback was sent (it may be sent while the judge holds a time), used for the pacing
only; the feedback, the result and the status are what arrived. The student's client
function is called by the agent against a server of the judge's own whose answer carries
a nonce: only a real call can return it, and only the judge counts the calls. The
messages are those of ``rosbook.labs.lab03``, which the in-kernel checks share.
"""

from __future__ import annotations

import secrets
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.node import Node
from std_msgs.msg import Int64, String
from std_srvs.srv import Trigger

from autograder.judge import (
    EVENT_GUARD_S,
    KERNEL_REPLY_GUARD_S,
    CheckFailed,
    Judgement,
    JudgeTimeout,
    KernelError,
    Unreadable,
    clock_message,
    clock_publisher,
    ros_node,
)
from autograder.judge_lab01 import (
    _ack,
    require_endpoint,
    require_name,
    wait_for,
    wait_until_discovered,
)
from rosbook.labs import lab03 as service_checks
from rosbook.labs.probes import Probe, assert_sequence
from rosbook.runtime.actions import GoalRun
from rosbook.runtime.callbacks import Callbacks, WakingExecutor
from rosbook.runtime.services import BackgroundServer, call
from rosbook.runtime.session import ros

#: Wall-clock seconds after which an unanswered /clock step is published again.
CLOCK_RETRY_S = 0.2
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
        self.acked: list[dict[str, Any]] = [_ack("")]
        self.acks = self.node.create_subscription(
            String,
            "/rosbook_judge/clock_ack",
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
        self.acked.append(_ack(msg.data))
        if self.acked[-1]["raised"]:
            # Whatever spins the judge's nodes now (a service call, a wait) stops here:
            # the node will not answer. ``finish`` then reads the error.
            raise NodeRaised(f"a callback of node '{self.name}' raised")

    @property
    def now(self) -> float:
        return self.t

    def advance(
        self, seconds: float, *nodes: Node, step: float = service_checks.SIM_STEP_S
    ) -> None:
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


def _raised_in_kernel(exc: KernelError, name: str) -> str:
    """What ``exc`` (a callback of node ``name`` raised it) says of the likely mistake."""
    kind, _, detail = str(exc).partition(": ")
    if kind == "TypeError":  # rclpy refuses to send what the service callback returned
        return service_checks.bad_response(TypeError(detail))
    if kind == "ZeroDivisionError":
        return service_checks.divided_by_rate(0.0)
    return f"a callback of node '{name}' raised {exc}"


@contextmanager
def kernel_errors_explained(name: str) -> Iterator[None]:
    try:
        yield
    except KernelError as exc:
        raise CheckFailed(_raised_in_kernel(exc, name)) from None


def _made(factory: str, kwargs: dict[str, Any]) -> str:
    return f"{factory}({', '.join(f'{k}={v!r}' for k, v in kwargs.items())})"


def check_clock_server(j: Judgement) -> None:
    for kwargs, name, times in (
        ({}, "clock_server", (12.5,)),
        ({"node_name": "clock_b"}, "clock_b", (3.25, 40.0)),
    ):
        ros.reset()
        info = j.start_node("ClockServer", sim_time=True, **kwargs)
        require_name(info, _made("ClockServer", kwargs), name)
        own = j.kernel.call("services")
        service_checks.assert_service_in(name, "/" + name, own, "what_time", Trigger)
        with kernel_errors_explained(name), remote_clock(j, name) as clock:
            for at in times:
                clock.advance(at - clock.now, step=at - clock.now)
                asker = ros_node("what_time_check_client")
                try:
                    with service_checks.call_failing("calling what_time"):
                        response = call(
                            asker, Trigger, "what_time", timeout=service_checks.DISCOVERY_S
                        )
                finally:
                    ros.remove(asker)
                service_checks.assert_told_time(response, at)


class RemoteNode:
    """The name of a node in the kernel, for checks that reach it from outside."""

    def __init__(self, name: str) -> None:
        self.name = name

    def get_name(self) -> str:
        return self.name

    def get_fully_qualified_name(self) -> str:
        return "/" + self.name


def _goal(clock: RemoteClock, order: int, cancel_after: int | None = None) -> GoalRun:
    """A countdown goal from the judge's client; feedback stamped with the kernel node's
    clock at each publish (sent while the judge holds a time, it is that time)."""
    before = len(clock.acked[-1]["feedback_at"])
    arrived = [0]
    clock.arrived = lambda published: arrived[0] >= published.get("feedback", 0) - before
    run = service_checks.countdown(
        clock,
        order,
        cancel_after,
        on_feedback=lambda _: arrived.__setitem__(0, arrived[0] + 1),
        on_ready=lambda: wait_until_discovered(
            clock.acked,
            clock.node,
            "/countdown/_action/feedback",
            service_checks.CLIENT_NODE,
            clock.name,
        ),
    )
    wait_for(
        lambda: len(clock.acked[-1]["feedback_at"]) >= before + len(run.feedback),
        clock.node,
        what="the kernel did not say when it sent the feedback",
        guard=LOCKSTEP_GUARD_S,
    )
    sent_at = clock.acked[-1]["feedback_at"][before : before + len(run.feedback)]
    run.feedback_times = [t / 1e9 for t in sent_at]
    return run


def check_countdown_action(j: Judgement) -> None:
    ros.init(sim_time=True)  # the judge's client reads the judge's /clock
    for kwargs, name, hidden in (
        ({}, "countdown_server", False),
        ({"node_name": "countdown_b"}, "countdown_b", True),
    ):
        ros.reset()
        info = j.start_node("CountdownServer", sim_time=True, **kwargs)
        require_name(info, _made("CountdownServer", kwargs), name)
        with kernel_errors_explained(name), remote_clock(j, name) as clock:
            if not hidden:
                service_checks.assert_counts_down(_goal(clock, 3), order=3, rate_hz=2.0)
                service_checks.assert_cancel_honoured(_goal(clock, 10, 3), rate_hz=2.0)
                continue
            server = RemoteNode(name)
            service_checks.assert_declared(server, "rate_hz", 2.0)  # type: ignore[arg-type]
            result = service_checks.set_from_outside(server, "rate_hz", 5.0)  # type: ignore[arg-type]
            if not result.successful:
                raise CheckFailed(f"setting rate_hz to 5.0 was refused: {result.reason!r}")
            service_checks.assert_counts_down(_goal(clock, 6), order=6, rate_hz=5.0)
            service_checks.assert_counts_down(_goal(clock, 0), order=0, rate_hz=5.0)
            service_checks.assert_cancel_honoured(_goal(clock, 20, 5), rate_hz=5.0)


def check_rate_parameter(j: Judgement) -> None:
    ros.init(sim_time=True)  # the judge's probe stamps ticks with the judge's /clock
    for kwargs, name, hidden in (
        ({}, "rate_publisher", False),
        ({"node_name": "rate_b"}, "rate_b", True),
    ):
        ros.reset()
        info = j.start_node("RatePublisher", sim_time=True, **kwargs)
        require_name(info, _made("RatePublisher", kwargs), name)
        require_endpoint(info, "/ticks", Int64, "publisher")
        j.wait_on_graph(name, "/ticks", "publisher")
        probe = Probe("ticks", Int64)
        with kernel_errors_explained(name), remote_clock(j, name) as clock:
            clock.arrived = lambda published, probe=probe: (
                len(probe.received.messages) >= published.get("/ticks", 0)
            )
            service_checks.assert_rate_follows(RemoteNode(name), clock, probe)  # type: ignore[arg-type]
        if hidden:
            data = [m.data for m in probe.received.messages]
            assert_sequence("'ticks'", data, list(range(len(data))))


def trigger_call(
    j: Judgement, service: str, timeout_s: float, deadline_s: float, server_up: bool
) -> tuple[Any, float]:
    """The student's ``call_trigger(node, service, timeout_s)``, run by the agent on a
    node of its own: (the value it returned, seconds it took)."""
    try:
        got = j.kernel.call(
            "call_trigger",
            "call_trigger",
            service,
            timeout_s,
            deadline_s,
            server_up,
            service_checks.DISCOVERY_S,
            guard=deadline_s + KERNEL_REPLY_GUARD_S,
        )
    except KernelError as exc:
        if "KeyError" in str(exc) and "call_trigger" in str(exc):
            raise CheckFailed("call_trigger is not defined: run its task's cell") from None
        raise
    if not got["discovered"]:
        raise JudgeTimeout(f"the judge's server on {service} was not discovered from the kernel")
    where = f"call_trigger(node, {service!r}, {timeout_s})"
    raised = got["raised"]
    if raised and raised[0] == "NotImplementedError":
        raise CheckFailed(f"{where}: this task is not done yet (NotImplementedError)")
    service_checks.assert_trigger_returned(
        where, deadline_s, got["finished"], got["unblocked"], tuple(raised) if raised else None
    )
    return _response(got["value"]), float(got["seconds"])


def _response(plain: dict[str, Any]) -> Any:
    """The returned value: a Trigger response rebuilt from its fields, None, or what the
    kernel could only describe."""
    if plain.get("type") == "NoneType":
        return None
    fields = plain.get("fields")
    if plain.get("type") == "Trigger_Response" and fields is not None:
        return Trigger.Response(success=bool(fields["success"]), message=str(fields["message"]))
    return Unreadable(plain["type"], plain.get("repr", repr(plain.get("value"))))


def _answering(message: str) -> Callable[[Any, Any], Any]:
    def answer(request: Any, response: Any) -> Any:
        response.success = True
        response.message = message
        return response

    return answer


def check_trigger_client(j: Judgement) -> None:
    for service in ("check_trigger", "/lab/other_trigger"):
        message = f"answered by the judge on {service} ({secrets.token_hex(4)})"
        with BackgroundServer(
            Trigger, service, _answering(message), node_name="trigger_check_server"
        ) as server:
            value, _ = trigger_call(j, service, 2.0, EVENT_GUARD_S, server_up=True)
        service_checks.assert_trigger_answered(value, server.calls, service, message)
    timeout_s = 0.5
    for service, slow_server in (("nobody_home", False), ("slow_trigger", True)):
        stopping = threading.Event()

        def slow(request: Any, response: Any, stopping: threading.Event = stopping) -> Any:
            stopping.wait(timeout_s + 2.0)
            response.success = True
            return response

        server = (
            BackgroundServer(Trigger, service, slow, node_name="slow_check_server")
            if slow_server
            else None
        )
        what = "a server slower than the timeout" if slow_server else "no server"
        try:
            # generous bounds: a loaded machine must not decide what "in time" is
            value, seconds = trigger_call(j, service, timeout_s, timeout_s + 5.0, slow_server)
        finally:
            stopping.set()
            if server is not None:
                server.close()
        service_checks.assert_trigger_gave_up(value, seconds, service, timeout_s, what, slack=3.0)


CHECKS = {
    "test_clock_server": check_clock_server,
    "test_trigger_client": check_trigger_client,
    "test_countdown_action": check_countdown_action,
    "test_rate_parameter": check_rate_parameter,
}
