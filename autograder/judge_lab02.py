"""Lab 2's checks as the judge runs them: verdicts from DDS traffic and returned values.

The student's functions build publishers and subscriptions on a node the agent makes in
the kernel; the judge is their peer on the sandbox's network: its late joiner subscribes
to /map, its lidar publishes on /scan (ranges shifted by a nonce the kernel cannot know
before they arrive), and the QoS each endpoint offers or asks for is read from the DDS
graph, not from the kernel. The model and compatibility functions are called with the
judge's inputs and their returned values compared, in this process, with the
references of ``rosbook.demos.qos``. The messages are those of ``rosbook.labs.lab02``.
"""

from __future__ import annotations

import random
from collections.abc import Iterator, Sequence
from typing import Any

from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String

from autograder.judge import (
    EVENT_GUARD_S,
    CheckFailed,
    Judgement,
    JudgeTimeout,
    KernelError,
    Unreadable,
    _python_value,
    ros_node,
)
from rosbook.demos.qos import predict_processed
from rosbook.labs import lab02 as qos_checks
from rosbook.labs.lockstep import (
    require_endpoint,
)
from rosbook.runtime.session import ros

#: Hang guard of a wait for a match across processes (or the event that says it never
#: comes): generous, the wait ends as soon as either happens.
MATCH_GUARD_S = 3 * EVENT_GUARD_S


def with_node(
    j: Judgement, function: str, node_name: str, call: str, *, collect: bool = False
) -> dict[str, Any]:
    """``function(node, [callback])`` run in the kernel on a fresh node ``node_name``."""
    try:
        return j.kernel.call("with_node", function, node_name, [], collect)  # type: ignore[no-any-return]
    except KernelError as exc:
        if "KeyError" in str(exc) and function in str(exc):
            raise CheckFailed(f"{function} is not defined: run its task's cell") from None
        if "NotImplementedError" in str(exc):
            raise CheckFailed(f"{call}: this task is not done yet (NotImplementedError)") from None
        raise CheckFailed(f"{call} raised {exc}") from None


def endpoint_qos(node_name: str, topic: str, kind: str) -> QoSProfile:
    """The QoS of ``node_name``'s ``kind`` endpoint on ``topic``, as DDS discovery tells
    the judge (never as the kernel says)."""
    watcher = ros_node("judge_qos_watcher")
    lookup = (
        watcher.get_publishers_info_by_topic
        if kind == "publisher"
        else watcher.get_subscriptions_info_by_topic
    )
    found: list[Any] = []

    def seen() -> bool:
        found[:] = [e for e in lookup(topic) if e.node_name == node_name]
        return bool(found)

    try:
        if not ros.spin_until(seen, watcher, timeout=EVENT_GUARD_S):
            raise JudgeTimeout(f"node '{node_name}' has no {kind} on {topic} on the ROS graph")
        return found[0].qos_profile  # type: ignore[no-any-return]
    finally:
        ros.remove(watcher)


def check_map_publisher(j: Judgement) -> None:
    for maps, node_name in (
        (["map v1", "map v2"], "map_server"),
        ([f"occupancy grid #{k}" for k in range(7)], "map_b"),
    ):
        ros.reset()
        call = "make_map_publisher(node)"
        info = with_node(j, "make_map_publisher", node_name, call)
        qos_checks.assert_returned(info["type"], info["repr"], qos_checks.Publisher, call)
        require_endpoint(info, "/map", String, "publisher")
        j.wait_on_graph(node_name, "/map", "publisher")
        offered = endpoint_qos(node_name, "/map", "publisher")
        if offered.depth == 0 and info.get("depth"):  # discovery does not tell the depth:
            offered.depth = info["depth"]  # the kernel's, for the message only
        j.kernel.call("publish_strings", maps)
        qos_checks.late_joiner_receives(maps, offered, guard=MATCH_GUARD_S)


def check_scan_subscription(j: Judgement) -> None:
    for count, node_name, at_least in ((3, "scan_listener", 1), (20, "scan_b", 15)):
        ros.reset()
        call = "make_scan_subscription(node, callback)"
        info = with_node(j, "make_scan_subscription", node_name, call, collect=True)
        qos_checks.assert_returned(info["type"], info["repr"], qos_checks.Subscription, call)
        require_endpoint(info, "/scan", LaserScan, "subscription")
        j.wait_on_graph(node_name, "/scan", "subscription")
        asked = endpoint_qos(node_name, "/scan", "subscription")
        base = random.SystemRandom().randrange(1, 4096) / 8  # exact in float32
        received: list[Any] = []
        with qos_checks.sensor_publisher(asked, guard=MATCH_GUARD_S) as publisher:
            if not j.kernel.call("scan_matched", EVENT_GUARD_S):
                raise JudgeTimeout(f"node '{node_name}' did not meet the judge's lidar")
            guard = EVENT_GUARD_S  # in lockstep: each scan is waited for, until one is lost
            for index in range(count):
                publisher.publish(qos_checks.make_scan(index, base))
                received = j.kernel.call("scans_until", index + 1, guard)
                if len(received) <= index:
                    guard = 0.1
            if len(received) < count:  # stragglers, after a loss
                received = j.kernel.call("scans_until", count, 1.0)
        qos_checks.assert_scans_received([(k, r) for k, r in received], count, base)
        if len(received) < at_least:
            raise CheckFailed(
                f"only {len(received)} of {count} scans sent one after the other arrived: "
                "is the subscription's depth too small for the callback to keep up?"
            )


#: Model cases only the judge knows (the lab's MODEL_CASES are in the student's view);
#: every tie of a finish and an arrival falls on exact binary floats, as there.
JUDGE_MODEL_CASES: tuple[tuple[float, float, int, float], ...] = (
    (4, 0.75, 2, 5),
    (2, 0.75, 1, 7),
    (8, 0.375, 3, 3),
    (1, 3.5, 3, 12),
    (16, 0.125, 2, 1),
)


def _listed(value: Any, call: str) -> list[Any]:
    if isinstance(value, Unreadable):
        raise CheckFailed(f"{call} returned {value!r}, not a list of ints")
    if not isinstance(value, (list, tuple)):
        return value  # type: ignore[no-any-return]
    return [int(v) if isinstance(v, float) and v.is_integer() else v for v in value]


def check_slow_subscriber_model(j: Judgement) -> None:
    def predict(*args: Any) -> Any:
        call = f"predict_processed({', '.join(repr(a) for a in args)})"
        return _listed(j.call_function("predict_processed", *args), call)

    cases = [(2, 1.7, 3, 6), (2, 1.7, 3, 4), *qos_checks.MODEL_CASES, *JUDGE_MODEL_CASES]
    qos_checks.assert_model_matches(predict, cases)
    assert predict_processed(2, 1.7, 3, 6) == [1, 2, 5, 9, 10, 11, 12]  # the reference's own


def qos_fields(qos: QoSProfile) -> dict[str, Any]:
    """Every field of ``qos``, for the agent to rebuild it in the kernel."""
    return {
        "history": int(qos.history),
        "depth": qos.depth,
        "reliability": int(qos.reliability),
        "durability": int(qos.durability),
        "deadline": qos.deadline.nanoseconds,
        "lifespan": qos.lifespan.nanoseconds,
        "liveliness": int(qos.liveliness),
        "lease": qos.liveliness_lease_duration.nanoseconds,
        "avoid": qos.avoid_ros_namespace_conventions,
    }


def incompatibility_pairs() -> list[tuple[QoSProfile, QoSProfile]]:
    reliable, best_effort = QoSProfile(depth=10), qos_profile_sensor_data
    transient = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    profiles = qos_checks.qos_profiles()
    return [
        (best_effort, reliable),
        (reliable, best_effort),
        (reliable, transient),
        *((p, s) for p in profiles for s in profiles),
    ]


def _answers(plain: Sequence[dict[str, Any]]) -> Iterator[Any]:
    """The kernel's answers as the student's function gave them (raised again)."""
    for answer in plain:
        if "raised" in answer:
            raised = type(str(answer["raised"]), (Exception,), {})
            raise raised(answer["message"])
        yield _python_value(answer)


def check_qos_incompatibilities(j: Judgement) -> None:
    pairs = incompatibility_pairs()
    try:
        plain = j.kernel.call(
            "qos_pairs",
            "incompatible_policies",
            [[qos_fields(p), qos_fields(s)] for p, s in pairs],
        )
    except KernelError as exc:
        if "KeyError" in str(exc):
            raise CheckFailed("incompatible_policies is not defined: run its task's cell") from None
        raise
    answers = _answers(plain)
    qos_checks.assert_incompatibilities_match(lambda pub, sub: next(answers), pairs)


CHECKS = {
    "test_map_publisher": check_map_publisher,
    "test_scan_subscription": check_scan_subscription,
    "test_slow_subscriber_model": check_slow_subscriber_model,
    "test_qos_incompatibilities": check_qos_incompatibilities,
}
