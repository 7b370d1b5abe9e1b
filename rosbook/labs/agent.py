"""The judge's agent in the student's kernel: builds and spins the student's code on request.

When a lab is graded, the judge (``autograder.judge``, a process of its own) imports this
module in the student's kernel, binds ``__rosbook_judge__ = JudgeAgent()`` there, and calls
its methods over a Jupyter client of its own; each call leaves its JSON answer in
``reply``. The agent builds the student's node with the judge's parameters, spins it
when asked and returns plain data (numbers, strings, lists of them). It runs as the
student, so the student's code may change or break it: that can only make the judge see
less, and seeing less never passes a check (the judge judges the ROS traffic it records
itself, and decodes each answer as plain data).
"""

from __future__ import annotations

import json
import pickle
import threading
import time
from typing import Any

import rclpy
from rclpy.action.server import ServerGoalHandle
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    LivelinessPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from rosgraph_msgs.msg import Clock
from std_msgs.msg import String

from rosbook.runtime.callbacks import Callbacks, WakingExecutor
from rosbook.runtime.services import run_with_deadline
from rosbook.runtime.session import ros

#: Where the agent says, during ``follow_clock``, how far the node has come.
ACK_TOPIC = "/rosbook_judge/clock_ack"


def student(name: str) -> Any:
    """The student's global ``name`` in the kernel (``KeyError`` when it is not defined)."""
    from IPython import get_ipython

    return get_ipython().user_ns[name]


def data(value: Any, depth: int = 0) -> dict[str, Any]:
    """``value`` as JSON the judge decodes itself (``rosbook.labs.remote.decode``):
    numbers, strings, None, and lists, tuples and string-keyed dicts of them; else its
    type and repr. Only exact built-in types count: an ``int`` subclass whose ``__eq__``
    the student wrote is described by its repr, never passed on as a number."""
    kind = type(value)
    if kind in (bool, int, float, str) or value is None:
        return {"type": kind.__name__, "value": value}
    if hasattr(value, "dtype") and hasattr(value, "tolist") and depth < 8:
        return data(value.tolist(), depth + 1)  # a numpy number or array: its numbers
    if depth < 8 and kind in (list, tuple):
        key = "tuple" if kind is tuple else "list"
        return {"type": kind.__name__, key: [data(v, depth + 1) for v in value]}
    if depth < 8 and kind is dict and all(type(k) is str for k in value):
        return {"type": "dict", "dict": [[k, data(v, depth + 1)] for k, v in value.items()]}
    if kind in (set, frozenset) and all(type(v) is str for v in value):
        return {"type": kind.__name__, "items": sorted(value)}
    return {"type": kind.__name__, "repr": repr(value)[:300]}


def argument(value: Any) -> Any:
    """An argument the judge sent (``rosbook.labs.remote.encode``) as the student's
    code takes it."""
    if isinstance(value, dict) and set(value) == {"parameter"}:
        name, given = value["parameter"]
        return Parameter(name, value=given)
    if isinstance(value, list):
        return [argument(v) for v in value]
    return value


def describe(value: Any) -> dict[str, Any]:
    """What the judge binds a student's name to: a class, a function, another object
    (handles, used through the agent), or a value (its plain data)."""
    import inspect

    if inspect.isclass(value):
        return {"kind": "class"}
    if callable(value):
        return {"kind": "function"}
    shown = data(value)
    if "repr" in shown:
        return {"kind": "object"}
    return {"kind": "value", "plain": shown}


def stamp_ns(time_msg: Any) -> int:
    return int(time_msg.sec) * 1_000_000_000 + int(time_msg.nanosec)


def qos_profile(fields: dict[str, Any]) -> QoSProfile:
    """A profile rebuilt from the fields the judge sent (``rosbook.labs.lab02.qos_fields``)."""
    return QoSProfile(
        history=HistoryPolicy(fields["history"]),
        depth=fields["depth"],
        reliability=ReliabilityPolicy(fields["reliability"]),
        durability=DurabilityPolicy(fields["durability"]),
        deadline=Duration(nanoseconds=fields["deadline"]),
        lifespan=Duration(nanoseconds=fields["lifespan"]),
        liveliness=LivelinessPolicy(fields["liveliness"]),
        liveliness_lease_duration=Duration(nanoseconds=fields["lease"]),
        avoid_ros_namespace_conventions=fields["avoid"],
    )


class JudgeAgent:
    """What the judge asks of the kernel; one per kernel (``__rosbook_judge__``)."""

    def __init__(self) -> None:
        self.node: Any = None
        self.executor: Any = None
        self.ackers: list[Node] = []
        self.reply: str | None = None
        self.made: Any = None
        self.collected: list[Any] = []
        self.background: threading.Thread | None = None
        self.quiet = threading.Event()

    def _answer(self, value: Any) -> None:
        self.reply = json.dumps(value)

    def take_reply(self) -> str | None:
        """The answer of the call that just ran, once (what the judge reads after each
        call): a call the kernel did not run (a cell run as something else in its place)
        leaves none, never the answer of an earlier one."""
        reply, self.reply = self.reply, None
        return reply

    # -- every lab -------------------------------------------------------------------

    def start(
        self,
        factory: str,
        kwargs: dict[str, Any],
        sim_time: bool,
        parameters: dict[str, Any] | None = None,
        background: bool = False,
    ) -> None:
        """Build the student's ``factory(**kwargs)`` (``parameters``: its overrides) in a
        fresh session; say what it is (name, endpoints). ``background``: spin it in a
        thread of the kernel's until ``stop`` (a wall-time node answers what the judge
        sends while the judge waits; each call of the judge's pauses it meanwhile)."""
        self.stop()
        ros.init(sim_time=sim_time)
        ros.hold_participant()  # the next check's node is seen at once: same participant
        ros.reset()
        if parameters:
            overrides = [Parameter(name, value=value) for name, value in parameters.items()]
            kwargs = dict(kwargs, parameter_overrides=overrides)
        self.node = student(factory)(**kwargs)
        self.executor = WakingExecutor()
        self.executor.add_node(self.node)
        name, ns = self.node.get_name(), self.node.get_namespace()
        self._answer(
            {
                "name": name,
                "namespace": ns,
                "publishers": self.node.get_publisher_names_and_types_by_node(name, ns),
                "subscriptions": self.node.get_subscriber_names_and_types_by_node(name, ns),
                "services": self.node.get_service_names_and_types_by_node(name, ns),
            }
        )
        if background:
            self._resume()

    def _spin_in_background(self) -> None:
        while not self.quiet.is_set():
            self.executor.spin_once(timeout_sec=0.01)

    def _pause(self) -> bool:
        """Stop spinning in the background; whether it was."""
        if self.background is None:
            return False
        self.quiet.set()
        self.background.join()
        self.background = None
        return True

    def _resume(self) -> None:
        self.quiet.clear()
        self.background = threading.Thread(
            target=self._spin_in_background, name="rosbook-judge-spin", daemon=True
        )
        self.background.start()

    # -- what the judge binds a test cell's names to ------------------------------------

    def describe(self, names: list[str]) -> None:
        """What each of the student's ``names`` is (``describe``); "missing" if undefined."""
        from IPython import get_ipython

        space = get_ipython().user_ns
        self._answer([describe(space[n]) if n in space else {"kind": "missing"} for n in names])

    def get(self, name: str) -> None:
        self._answer(data(student(name)))

    def call(self, name: str, args: list[Any], kwargs: dict[str, Any]) -> None:
        """Call the student's function ``name(*args, **kwargs)`` (arguments as the judge
        sent them, ``argument``)."""
        given = {k: argument(v) for k, v in kwargs.items()}
        self._answer(data(student(name)(*[argument(a) for a in args], **given)))

    def attribute(self, attribute: str) -> None:
        """The started node's ``attribute`` (an ``AttributeError`` if it has none); a
        method is said to be one (the judge calls it with ``call_method``)."""
        spinning = self._pause()
        try:
            value = getattr(self.node, attribute)
            self._answer({"method": True} if callable(value) else data(value))
        finally:
            if spinning:
                self._resume()

    def call_method(self, attribute: str, args: list[Any]) -> None:
        """Call the started node's method ``attribute`` with ``args`` (plain data, and
        ``{"parameter": [name, value]}`` for an ``rclpy.parameter.Parameter``)."""
        spinning = self._pause()
        try:
            self._answer(data(getattr(self.node, attribute)(*[argument(a) for a in args])))
        finally:
            if spinning:
                self._resume()

    def call_to_file(self, name: str, path: str) -> None:
        """Pickle what the student's ``name()`` returns into ``path``, for a program the
        judge starts as the student (the judge itself never unpickles it); say its type,
        and why it could not be pickled, if so."""
        value = student(name)()
        error = None
        try:
            with open(path, "wb") as f:
                pickle.dump(value, f)
        except Exception as exc:  # noqa: BLE001 - the student's object: said, not raised
            error = f"{type(exc).__name__}: {exc}"[:300]
        self._answer(data({"type": type(value).__name__, "error": error}))

    def follow_clock(self, until: float, guard: float, gate: str | None = None) -> None:
        """Spin the node on the judge's /clock up to ``until``. After each new time, once
        its due callbacks ran, say on ``ACK_TOPIC`` the time and how many messages it has
        published on each topic, and action feedback messages under "feedback" (the judge
        waits for them to arrive, then publishes the next time); "feedback_at" lists the
        node's clock (ns) at each feedback, for the pacing of an action, whose feedback
        can be sent while the judge holds a time; "taken" counts the messages its
        subscriptions' callbacks took, by topic (said again at once when it grows: the
        judge sends a sensor reading and waits for it to be taken before it moves time
        on); "readers" lists, by topic the node publishes on, the subscriptions (GIDs) its
        participant has discovered: a publisher sends only to those it knows, so the judge
        waits to be among them before it lets the node send.

        When a callback of the node raises, a last ack says so ("raised") and the error
        ends the call.

        With ``gate`` (a topic the node subscribes to), the reading carries the time:
        once the node has taken a message on ``gate`` stamped T, its /clock subscriptions
        get time T (a /clock message for T, made here), so its timers at T run after its
        callback took the reading; a /clock message from the judge for a time not reached
        yet is held until then (one message and one round trip per step)."""
        node = self.node
        acker = rclpy.create_node("rosbook_judge_agent")
        ack = acker.create_publisher(String, ACK_TOPIC, 10)
        counts: dict[str, int] = {}
        feedback_at: list[int] = []
        original = Publisher.publish
        original_feedback = ServerGoalHandle.publish_feedback

        def counted(publisher: Publisher, msg: Any) -> None:
            counts[publisher.topic_name] = counts.get(publisher.topic_name, 0) + 1
            original(publisher, msg)

        def counted_feedback(handle: ServerGoalHandle, feedback: Any) -> None:
            counts["feedback"] = counts.get("feedback", 0) + 1
            feedback_at.append(node.get_clock().now().nanoseconds)
            original_feedback(handle, feedback)

        name, ns = node.get_name(), node.get_namespace()
        sending = [
            topic
            for topic, _ in node.get_publisher_names_and_types_by_node(name, ns)
            if topic not in ("/rosout", "/parameter_events")
        ]

        # Listing the readers is a graph query: listed afresh when the node's publishers'
        # match counts change, and on each repeated ack (while the judge waits to be known).
        matching = [p for p in node.publishers if p.topic_name in sending]
        listed: dict[str, Any] = {"counts": None, "readers": {}}

        def readers(fresh: bool) -> dict[str, list[str]]:
            counts_now = [p.get_subscription_count() for p in matching]
            if fresh or counts_now != listed["counts"]:
                listed["counts"] = counts_now
                listed["readers"] = {
                    topic: [
                        bytes(e.endpoint_gid).hex()
                        for e in acker.get_subscriptions_info_by_topic(topic)
                    ]
                    for topic in sending
                }
            return listed["readers"]  # type: ignore[no-any-return]

        taken: dict[str, int] = {}
        callbacks = []
        # the latest stamp taken on the gate (a message without a header releases every
        # held time), and the latest time a reading carried
        gated = {"stamp": -1, "time": -1}
        # per /clock subscription: [its held message, its own callback, the time it has]
        holders: list[list[Any]] = []
        target = int(round(until * 1e9))

        def deliver(holder: list[Any], msg: Any) -> None:
            if stamp_ns(msg.clock) > holder[2]:  # time only moves on
                holder[2] = stamp_ns(msg.clock)
                holder[1](msg)

        def release() -> None:
            for holder in holders:
                held = holder[0]
                if held is not None and gated["stamp"] >= stamp_ns(held.clock):
                    holder[0] = None
                    deliver(holder, held)
                if gated["time"] > holder[2]:
                    carried = Clock()
                    carried.clock.sec, carried.clock.nanosec = divmod(gated["time"], 10**9)
                    deliver(holder, carried)

        for sub in node.subscriptions:
            callbacks.append((sub, sub.callback))
            if sub.topic_name == "/clock":
                if gate is not None:
                    holder: list[Any] = [None, sub.callback, -1]
                    holders.append(holder)

                    def holding(msg: Any, _holder: list[Any] = holder) -> None:
                        if stamp_ns(msg.clock) >= target:  # the end: never held
                            _holder[0] = None
                            deliver(_holder, msg)
                        else:
                            _holder[0] = msg
                            release()

                    sub.callback = holding
                continue

            def taking(*args: Any, _sub: Any = sub, _callback: Any = sub.callback) -> Any:
                if _sub.topic_name == gate:  # taken, whatever its callback then does
                    header = getattr(args[0], "header", None)
                    gated["stamp"] = max(
                        gated["stamp"], stamp_ns(header.stamp) if header is not None else 1 << 62
                    )
                    if header is not None:
                        gated["time"] = max(gated["time"], stamp_ns(header.stamp))
                result = _callback(*args)
                taken[_sub.topic_name] = taken.get(_sub.topic_name, 0) + 1
                if _sub.topic_name == gate:
                    release()
                return result

            sub.callback = taking
        said = -1
        # the node's callbacks as a lockstep runs them: passes, then rcl's wait on a kept
        # wait set (rclpy's executor builds one per callback and wakes once more after it)
        runner = Callbacks([node], self.executor)
        Publisher.publish = counted  # type: ignore[method-assign]
        ServerGoalHandle.publish_feedback = counted_feedback  # type: ignore[method-assign]
        last = -1
        sent = 0.0
        msg = String()
        deadline = time.monotonic() + guard
        try:
            while ack.get_subscription_count() == 0 and time.monotonic() < deadline:
                time.sleep(0.01)
            while True:
                now = node.get_clock().now().nanoseconds
                if now > last:
                    runner.round()  # every callback due now, and what they make ready
                    last, sent = now, 0.0
                    deadline = time.monotonic() + guard
                if sum(taken.values()) != said:
                    said, sent = sum(taken.values()), 0.0
                if time.monotonic() - sent > 0.1:  # again, while the judge waits for it
                    msg.data = json.dumps(
                        {
                            "now": last,
                            "published": counts,
                            "feedback_at": feedback_at,
                            "taken": taken,
                            "readers": readers(fresh=sent > 0.0),
                        }
                    )
                    ack.publish(msg)
                    sent = time.monotonic()
                    if last >= target:
                        self._answer({"timeout": False})
                        return
                if time.monotonic() > deadline:
                    self._answer({"timeout": True})
                    return
                runner.spin(0.01)
        except Exception:
            # A callback of the node raised: say so at once, so that the judge stops
            # waiting for what the node will no longer do; the error ends this call.
            msg.data = json.dumps({"now": last, "published": counts, "raised": True})
            ack.publish(msg)
            raise
        finally:
            Publisher.publish = original  # type: ignore[method-assign]
            ServerGoalHandle.publish_feedback = original_feedback  # type: ignore[method-assign]
            for sub, callback in callbacks:
                sub.callback = callback
            self.ackers.append(acker)  # destroyed by stop(): the last ack must get out

    def await_writers(self, topic: str, gids: list[str], guard: float) -> None:
        """Wait until this participant has discovered every publisher ``gids`` on
        ``topic`` and the node's subscriptions on it have matched a publisher (the node
        takes nothing from one it has not: what that one sent before is lost, not late);
        whether they have, within ``guard`` seconds."""
        subscriptions = [s for s in self.node.subscriptions if s.topic_name == topic]
        self._await_known(
            self.node.get_publishers_info_by_topic,
            topic,
            gids,
            guard,
            lambda: all(s.get_publisher_count() > 0 for s in subscriptions),
        )

    def await_readers(self, topic: str, gids: list[str], guard: float) -> None:
        """Wait until this participant has discovered every subscription ``gids`` on
        ``topic`` and the node's publishers on it have matched one (a publisher sends
        only to those it knows)."""
        publishers = [p for p in self.node.publishers if p.topic_name == topic]
        self._await_known(
            self.node.get_subscriptions_info_by_topic,
            topic,
            gids,
            guard,
            lambda: all(p.get_subscription_count() > 0 for p in publishers),
        )

    def _await_known(
        self, infos: Any, topic: str, gids: list[str], guard: float, matched: Any
    ) -> None:
        spinning = self._pause()  # the graph and the match counts, read between spins
        try:
            end = time.monotonic() + guard
            while True:
                known = {bytes(e.endpoint_gid).hex() for e in infos(topic)}
                done = set(gids) <= known and matched()
                if done or time.monotonic() > end:
                    break
                time.sleep(0.01)
            self._answer(done)
        finally:
            if spinning:
                self._resume()

    def spin_until_length(self, attribute: str, length: int, guard: float) -> None:
        end = time.monotonic() + guard
        while len(getattr(self.node, attribute, None) or ()) < length:
            if time.monotonic() > end:
                break
            self.executor.spin_once(timeout_sec=0.01)
        value = getattr(self.node, attribute, None)
        self._answer(list(value) if isinstance(value, (list, tuple)) else repr(value))

    def stop(self) -> None:
        self._pause()
        if self.executor is not None:
            self.executor.shutdown(timeout_sec=0)
        if self.node is not None:
            self.node.destroy_node()
        for acker in self.ackers:
            acker.destroy_node()
        self.ackers = []
        self.node = self.executor = None
        self._answer(None)

    # -- lab 2: the student's function given a node of the agent's (and a callback that
    # keeps what it is called with), publishing through what it returned, and the
    # compatibility function called on profiles rebuilt from their fields ----------------

    def with_node(self, function: str, node_name: str, args: list[Any], collect: bool) -> None:
        self.stop()
        ros.init()
        ros.reset()
        self.node = Node(node_name)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.collected = []
        keep = [self.collected.append] if collect else []
        self.made = student(function)(self.node, *args, *keep)
        name, ns = self.node.get_name(), self.node.get_namespace()
        depth = getattr(getattr(self.made, "qos_profile", None), "depth", None)
        self._answer(
            {
                "type": type(self.made).__name__,
                "repr": repr(self.made)[:200],
                "name": name,
                "publishers": self.node.get_publisher_names_and_types_by_node(name, ns),
                "subscriptions": self.node.get_subscriber_names_and_types_by_node(name, ns),
                "depth": depth if type(depth) is int else None,
            }
        )

    def publish_strings(self, texts: list[str]) -> None:
        for text in texts:
            self.made.publish(String(data=text))
        self._answer(None)

    def scans_until(self, count: int, guard: float) -> None:
        from sensor_msgs.msg import LaserScan

        end = time.monotonic() + guard
        while len(self.collected) < count and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.01)
        self._answer(
            [
                [type(m).__name__, list(m.ranges) if isinstance(m, LaserScan) else []]
                for m in self.collected
            ]
        )

    def scan_matched(self, guard: float) -> None:
        """Spin until the subscription met the judge's publisher from its side too (a
        best-effort message sent before that is lost); how many publishers it has."""
        end = time.monotonic() + guard
        while self.made.get_publisher_count() == 0 and time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.01)
        self._answer(self.made.get_publisher_count())

    def qos_pairs(self, function: str, pairs: list[list[dict[str, Any]]]) -> None:
        answers = []
        for pub, sub in pairs:
            try:
                answers.append(data(student(function)(qos_profile(pub), qos_profile(sub))))
            except Exception as exc:  # noqa: BLE001 - the student's function: said
                answers.append({"raised": type(exc).__name__, "message": str(exc)[:300]})
        self._answer(answers)

    # -- lab 3 -------------------------------------------------------------------------

    def call_trigger(
        self,
        function: str,
        service: str,
        timeout_s: float,
        deadline_s: float,
        server_up: bool,
        discovery: float,
    ) -> None:
        from std_srvs.srv import Trigger

        self.stop()
        ros.init()
        self.node = node = Node("trigger_check_client")
        if server_up:  # so that timeout_s is spent on the call, not on discovery
            seen = node.create_client(Trigger, service)
            found = seen.wait_for_service(timeout_sec=discovery)
            node.destroy_client(seen)
            if not found:
                self._answer({"discovered": False})
                return
        call = student(function)
        outcome = run_with_deadline(lambda: call(node, service, timeout_s), deadline_s)
        finished = outcome.finished
        unblocked = not finished and ros.spin_until(lambda: outcome.finished, node, timeout=1.0)
        value = outcome.value
        shown = data(value)
        if hasattr(value, "get_fields_and_field_types"):
            fields = {k: getattr(value, k) for k in value.get_fields_and_field_types()}
            if all(isinstance(v, (bool, int, float, str)) for v in fields.values()):
                shown["fields"] = fields
        error = outcome.error
        self._answer(
            {
                "discovered": True,
                "finished": finished,
                "unblocked": bool(unblocked),
                "raised": None if error is None else [type(error).__name__, str(error)[:300]],
                "value": shown,
                "seconds": outcome.seconds,
            }
        )
