"""Checks for lab 2 (QoS): a student's publishers and subscriptions against real DDS peers,
their KEEP_LAST model against the reference, their compatibility rules against rclpy's.

Every failure is a ``CheckFailed`` (an ``AssertionError``) that names the mistake (a
VOLATILE publisher for a late joiner, a RELIABLE subscription to a sensor stream, a queue
one message too deep).

When graded, the student's functions are handles into the student's kernel
(``rosbook.labs.remote``) and each check takes its graded branch: the publisher or
subscription is made there, on a node of the judge's agent, and the judge is its peer on
the sandbox's network (its late joiner subscribes to /map, its lidar publishes on /scan,
with ranges shifted by a nonce the kernel cannot know before they arrive); the QoS each
endpoint offers or asks for is read from the DDS graph, never from the kernel. The model
and compatibility functions are called there with the cell's inputs, and what they
returned is compared here, as plain data.
"""

from __future__ import annotations

import itertools
import random
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from rclpy.duration import Duration
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import (
    DurabilityPolicy,
    LivelinessPolicy,
    QoSPolicyKind,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_parameters,
    qos_profile_sensor_data,
    qos_profile_services_default,
    qos_profile_system_default,
)
from rclpy.subscription import Subscription
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String

from rosbook.demos.qos import POLICIES, predict_processed, rclpy_incompatible_policies
from rosbook.labs.deferral import deferrable
from rosbook.labs.probes import (
    MATCH_TIMEOUT_S,
    CheckFailed,
    make_node,
    node_publishes,
    node_subscribes,
)
from rosbook.labs.remote import (
    EVENT_GUARD_S,
    Judgement,
    JudgeTimeout,
    KernelError,
    Student,
    Unreadable,
    decode,
    is_student,
    judgement,
    ros_node,
)
from rosbook.runtime.session import ros

#: When graded, the guard of a wait for a match with the student's node in its kernel
#: (or the event that says it never comes): generous, the wait ends as soon as either
#: happens.
MATCH_GUARD_S = 3 * EVENT_GUARD_S

#: How a typical late joiner (a map display, say) subscribes.
LATE_JOINER_QOS = QoSProfile(
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)


def describe(qos: QoSProfile) -> str:
    """``RELIABLE, VOLATILE, depth 10, deadline 1 s``: the policies a mismatch is about."""
    deadline = qos.deadline.nanoseconds
    parts = [qos.reliability.name, qos.durability.name, f"depth {qos.depth}"]
    # DDS discovery reports an unset deadline as the infinite one (2**63 - 1 ns)
    parts.append(f"deadline {deadline / 1e9:g} s" if 0 < deadline < 2**63 - 1 else "no deadline")
    return ", ".join(parts)


def _policy(info: Any) -> str:
    return QoSPolicyKind(info.last_policy_kind).name


def _returned(value: Any, kind: type, call: str) -> None:
    if not isinstance(value, kind):
        assert_returned(type(value).__name__, repr(value), kind, call)


def assert_returned(type_name: str, text: str, kind: type, call: str) -> None:
    """``call`` returned a ``type_name`` (shown as ``text``): it must be a ``kind``."""
    if type_name != kind.__name__:
        raise CheckFailed(
            f"{call} returned {type_name} ({text}); it must return the "
            f"{kind.__name__} it created (return node.create_...(...))"
        )


def _made_in_kernel(
    j: Judgement, function: Student, node_name: str, call: str, collect: bool = False
) -> dict[str, Any]:
    """Graded: the student's ``function(node)`` (with ``collect``: ``function(node,
    callback)``, the callback keeping what it gets) run in the kernel on a fresh node
    ``node_name`` of the agent's; what it returned (type, repr) and the node's endpoints,
    as the kernel says them (which only shortens a failure: a pass needs the traffic)."""
    from rosbook.labs.lockstep import require_endpoint  # judge-side (lab 3's clock too)

    try:
        made: dict[str, Any] = j.kernel.call("with_node", function.name, node_name, [], collect)
    except KernelError as exc:  # the student's function raised
        if "NotImplementedError" in str(exc):
            raise CheckFailed(f"{call}: this task is not done yet (NotImplementedError)") from None
        raise CheckFailed(f"{call} raised {exc}") from None
    kind, topic, msg_type = (
        (Subscription, "/scan", LaserScan) if collect else (Publisher, "/map", String)
    )
    assert_returned(str(made["type"]), str(made["repr"]), kind, call)
    require_endpoint(made, topic, msg_type, kind.__name__.lower())
    j.wait_on_graph(node_name, topic, kind.__name__.lower())
    return made


def _endpoint_qos(node_name: str, topic: str, kind: str) -> QoSProfile:
    """The QoS of ``node_name``'s ``kind`` endpoint ("publisher" or "subscription") on
    ``topic``, as DDS discovery tells this process (never as the node's own process says)."""
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


# -- map_publisher ----------------------------------------------------------------------


def assert_late_joiner_gets_last(
    make_map_publisher: Callable[[Node], Publisher],
    maps: Sequence[str],
    node_name: str = "map_server",
    joiner_qos: QoSProfile = LATE_JOINER_QOS,
) -> list[str]:
    """Publish ``maps`` with nobody listening, then subscribe: the last must still arrive.

    Returns what the late joiner received. Graded (``make_map_publisher`` a handle): the
    publisher is made and publishes in the student's kernel.
    """
    ros.reset()
    if is_student(make_map_publisher):
        j = judgement()
        made = _made_in_kernel(j, make_map_publisher, node_name, "make_map_publisher(node)")
        offered = _endpoint_qos(node_name, "/map", "publisher")
        if offered.depth == 0 and type(made.get("depth")) is int:  # discovery does not
            offered.depth = made["depth"]  # tell the depth: the kernel's, for the message
        j.kernel.call("publish_strings", [str(text) for text in maps])
        return late_joiner_receives(maps, offered, joiner_qos, guard=MATCH_GUARD_S)
    node = Node(node_name)
    publisher = make_node(make_map_publisher, node)
    _returned(publisher, Publisher, "make_map_publisher(node)")
    node_publishes(node, "map", String)
    for text in maps:
        publisher.publish(String(data=text))
    ros.spin_for(0.05, node)
    return late_joiner_receives(maps, publisher.qos_profile, joiner_qos)


def late_joiner_receives(
    maps: Sequence[str],
    offered: QoSProfile,
    joiner_qos: QoSProfile = LATE_JOINER_QOS,
    guard: float = MATCH_TIMEOUT_S,
) -> list[str]:
    """Subscribe to /map once ``maps`` were published by a publisher offering ``offered``
    (in this process or another): the last must arrive. Returns what arrived.

    ``guard`` bounds the waits for the match (or an incompatible-QoS event) and for the
    message: both end as soon as what they wait for happens."""
    events: list[str] = []
    got: list[str] = []
    joiner = Node("late_joiner")
    subscription = joiner.create_subscription(
        String,
        "map",
        lambda msg: got.append(msg.data),
        joiner_qos,
        event_callbacks=SubscriptionEventCallbacks(
            incompatible_qos=lambda info: events.append(_policy(info))
        ),
    )
    ros.spin_until(
        lambda: subscription.get_publisher_count() > 0 or bool(events),
        joiner,
        timeout=guard,
    )
    if events or subscription.get_publisher_count() == 0:
        if offered.durability != DurabilityPolicy.TRANSIENT_LOCAL:
            raise CheckFailed(
                f"a subscriber that joins after the last publish (TRANSIENT_LOCAL, as map "
                f"displays subscribe) cannot even connect: your publisher is "
                f"{describe(offered)}. A {offered.durability.name} publisher keeps nothing "
                "for late joiners; use durability=DurabilityPolicy.TRANSIENT_LOCAL."
            )
        raise CheckFailed(
            f"the late joiner ({describe(joiner_qos)}) does not connect to your publisher "
            f"({describe(offered)}); incompatible policy reported: "
            f"{', '.join(events) or 'none'}. A late joiner asks for RELIABLE delivery."
        )
    ros.spin_until(lambda: maps[-1] in got, joiner, timeout=guard)
    ros.spin_for(0.05, joiner)
    ros.remove(joiner)
    if not got:
        raise CheckFailed(
            f"published {list(maps)!r} on /map before anyone subscribed; a late joiner "
            f"received nothing. Your publisher is {describe(offered)}: it must keep the "
            "last message for late joiners (TRANSIENT_LOCAL, depth at least 1)."
        )
    if got[-1] != maps[-1]:
        raise CheckFailed(
            f"published {list(maps)!r} before the late joiner subscribed; it received "
            f"{got!r}, and the last message it got is not the last one published."
        )
    return got


# -- scan_subscription ------------------------------------------------------------------


def make_scan(index: int, base: float = 0.0) -> LaserScan:
    """The ``index``-th scan a check sends (``base`` shifts its ranges: a judge's nonce)."""
    scan = LaserScan()
    scan.header.frame_id = "laser"
    scan.angle_min, scan.angle_max, scan.angle_increment = -1.0, 1.0, 0.5
    scan.range_min, scan.range_max = 0.1, 10.0
    scan.ranges = [base + float(index) + 0.25 * k for k in range(5)]
    return scan


def assert_receives_sensor_data(
    make_scan_subscription: Callable[[Node, Callable[[Any], None]], Subscription],
    count: int,
    node_name: str = "scan_listener",
    sensor_qos: QoSProfile = qos_profile_sensor_data,
) -> list[LaserScan]:
    """A publisher with ``sensor_qos`` sends ``count`` scans; the callback must get them.
    Graded (``make_scan_subscription`` a handle): the subscription is made in the
    student's kernel (``_scans_in_kernel``); what it got is returned as ``scan_seen``
    pairs."""
    ros.reset()
    if is_student(make_scan_subscription):
        return _scans_in_kernel(  # type: ignore[return-value]
            judgement(), make_scan_subscription, count, node_name, sensor_qos
        )
    node = Node(node_name)
    got: list[LaserScan] = []
    subscription = make_node(make_scan_subscription, node, got.append)
    _returned(subscription, Subscription, "make_scan_subscription(node, callback)")
    node_subscribes(node, "scan", LaserScan)
    with sensor_publisher(subscription.qos_profile, sensor_qos) as publisher:
        for index in range(count):
            publisher.publish(make_scan(index))
            ros.spin_for(0.01)
        ros.spin_until(lambda: len(got) >= count, timeout=1.0)
    assert_scans_received([scan_seen(m) for m in got], count)
    return got


def _scans_in_kernel(
    j: Judgement, function: Student, count: int, node_name: str, sensor_qos: QoSProfile
) -> list[tuple[str, list[float]]]:
    """Graded ``assert_receives_sensor_data``: the judge's lidar sends each scan once the
    last one was taken in the kernel (in lockstep, until one is lost: a best-effort
    stream may drop, then the rest go without waiting), its ranges shifted by a nonce."""
    _made_in_kernel(j, function, node_name, "make_scan_subscription(node, callback)", True)
    asked = _endpoint_qos(node_name, "/scan", "subscription")
    base = random.SystemRandom().randrange(1, 4096) / 8  # exact in float32
    received: list[Any] = []
    with sensor_publisher(asked, sensor_qos, guard=MATCH_GUARD_S) as publisher:
        if not j.kernel.call("scan_matched", EVENT_GUARD_S):
            raise JudgeTimeout(f"node '{node_name}' did not meet the judge's lidar")
        guard = EVENT_GUARD_S
        for index in range(count):
            publisher.publish(make_scan(index, base))
            received = j.kernel.call("scans_until", index + 1, guard)
            if len(received) <= index:
                guard = 0.1
        if len(received) < count:  # stragglers, after a loss
            received = j.kernel.call("scans_until", count, 1.0)
    seen = [(str(kind), [float(r) for r in ranges]) for kind, ranges in received]
    assert_scans_received(seen, count, base)
    return seen


@contextmanager
def sensor_publisher(
    asked: QoSProfile,
    sensor_qos: QoSProfile = qos_profile_sensor_data,
    guard: float = MATCH_TIMEOUT_S,
) -> Iterator[Publisher]:
    """A LaserScan publisher on /scan with ``sensor_qos``, once it met the subscription
    that asked for ``asked`` (in this process or another; ``guard`` bounds the wait for
    the match or an incompatible-QoS event); gone afterwards."""
    events: list[str] = []
    sensor = Node("lidar_driver")
    try:
        publisher = sensor.create_publisher(
            LaserScan,
            "scan",
            sensor_qos,
            event_callbacks=PublisherEventCallbacks(
                incompatible_qos=lambda info: events.append(_policy(info))
            ),
        )
        ros.spin_until(
            lambda: publisher.get_subscription_count() > 0 or bool(events),
            sensor,
            timeout=guard,
        )
        if events or publisher.get_subscription_count() == 0:
            if asked.reliability == ReliabilityPolicy.RELIABLE:
                raise CheckFailed(
                    f"your subscription ({describe(asked)}) asks for RELIABLE delivery, which "
                    f"a BEST_EFFORT sensor publisher ({describe(sensor_qos)}, that is "
                    "qos_profile_sensor_data) does not offer: they never connect and the "
                    "callback is never called. Subscribe with qos_profile_sensor_data."
                )
            raise CheckFailed(
                f"your subscription ({describe(asked)}) does not connect to a publisher using "
                f"qos_profile_sensor_data; incompatible policy: {', '.join(events) or 'none'}."
            )
        yield publisher
    finally:
        ros.remove(sensor)


def scan_seen(msg: Any) -> tuple[str, list[float]]:
    """What a check needs of a message the callback got: its type's name and its ranges."""
    return type(msg).__name__, list(msg.ranges) if isinstance(msg, LaserScan) else []


def assert_scans_received(
    received: Sequence[tuple[str, list[float]]], count: int, base: float = 0.0
) -> None:
    """``received`` (``scan_seen`` of each message the callback got) are scans sent."""
    if not received:
        raise CheckFailed(
            f"the subscription is connected but the callback received none of {count} "
            "scans: does make_scan_subscription pass `callback` to create_subscription?"
        )
    if any(kind != "LaserScan" for kind, _ in received):
        raise CheckFailed("the callback must receive the LaserScan messages themselves")
    expected = [list(make_scan(i, base).ranges) for i in range(count)]
    if any(ranges not in expected for _, ranges in received):
        raise CheckFailed("the scans the callback received differ from those sent")


# -- slow_subscriber_model --------------------------------------------------------------

#: (publish_hz, callback_s, depth, duration_s) sets the hidden check uses. Where a finish
#: and an arrival meet (the tie rule), both instants are exact binary floats, so any
#: correct float implementation agrees with the exact reference.
MODEL_CASES: tuple[tuple[float, float, int, float], ...] = (
    (2, 1.7, 3, 6),
    (2, 1.7, 3, 4),
    (2, 1.7, 1, 6),
    (2, 1.7, 5, 8),
    (2, 1.7, 3, 5.2),
    (2, 0.1, 3, 6),
    (2, 0.5, 1, 4),
    (2, 1.5, 1, 3),
    (4, 0.75, 2, 3),
    (1, 2.5, 2, 10),
    (10, 0.37, 2, 2),
    (5, 1.33, 4, 6),
    (2, 1.7, 3, 0),
    (1, 5.0, 100, 4),
)


def assert_model_matches(
    predict: Callable[[float, float, int, float], Sequence[int]],
    cases: Sequence[tuple[float, float, int, float]],
) -> None:
    """``predict`` must give the reference answer on every case; explain the first miss.
    (Graded, ``predict`` is a handle: each case is called in the student's kernel.)"""
    for hz, work, depth, duration in cases:
        call = f"predict_processed({hz!r}, {work!r}, {depth!r}, {duration!r})"
        try:
            got = predict(hz, work, depth, duration)
        except CheckFailed:  # already says what happened (a judge's call into a kernel)
            raise
        except Exception as exc:  # the student's function failed: say where
            raise CheckFailed(f"{call} raised {type(exc).__name__}: {exc}") from None
        if not isinstance(got, (list, tuple)):
            kind = got.type_name if isinstance(got, Unreadable) else type(got).__name__
            raise CheckFailed(f"{call} returned {kind}, not a list of ints")
        got = list(got)
        want = predict_processed(hz, work, depth, duration)
        if got == want:
            continue
        hint = _model_hint(got, hz, work, depth, duration)
        raise CheckFailed(f"{call} returned {got}, expected {want}. {hint}")


def _model_hint(got: list[int], hz: float, work: float, depth: int, duration: float) -> str:
    """Name the usual mistake when ``got`` is what it would produce."""
    for other in (depth - 1, depth + 1):
        if other >= 1 and got == predict_processed(hz, work, other, duration):
            return (
                f"That is the answer for a queue of depth {other}: the queue holds at most "
                "`depth` messages that wait; the one the callback works on has left it."
            )
    if got == predict_processed(hz, work, depth, duration + 0.5 / hz):
        return "Messages are published while t < duration_s, not t <= duration_s."
    want = predict_processed(hz, work, depth, duration)
    if got and got == want[: len(got)]:
        return "After the last publish the subscriber still drains its queue."
    if sorted(got) != got:
        return "The callback takes messages oldest first."
    return (
        "Walk through the arrivals one by one: an idle callback starts at once, a full "
        "queue drops its oldest, a finish at the instant of an arrival comes first."
    )


# -- qos_incompatibilities --------------------------------------------------------------


def qos_profiles() -> list[QoSProfile]:
    """Profiles across the three policies, plus rclpy's predefined ones."""
    made = [
        QoSProfile(
            depth=depth,
            reliability=reliability,
            durability=durability,
            deadline=Duration(seconds=deadline),
            liveliness=LivelinessPolicy.AUTOMATIC,
        )
        for (reliability, durability, deadline), depth in zip(
            itertools.product(
                (ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT),
                (DurabilityPolicy.VOLATILE, DurabilityPolicy.TRANSIENT_LOCAL),
                (0, 0.1, 1.0, 2.5),
            ),
            itertools.cycle((1, 5, 10)),
        )
    ]
    return made + [
        qos_profile_sensor_data,
        qos_profile_system_default,
        qos_profile_services_default,
        qos_profile_parameters,
        QoSProfile(depth=10),
    ]


def assert_incompatibilities_match(
    incompatible: Callable[[QoSProfile, QoSProfile], Any],
    pairs: Sequence[tuple[QoSProfile, QoSProfile]],
) -> None:
    """``incompatible(pub, sub)`` must name exactly the policies rclpy's check rejects.
    (Graded, ``incompatible`` is a handle: every pair is called in the student's kernel
    at once, ``_incompatible_in_kernel``.)"""
    if is_student(incompatible):
        incompatible = _incompatible_in_kernel(judgement(), incompatible, pairs)
    for pub, sub in pairs:
        call = f"incompatible_policies(publisher: {describe(pub)}; subscription: {describe(sub)})"
        try:
            got = incompatible(pub, sub)
        except CheckFailed:
            raise
        except Exception as exc:  # the student's function failed: say how
            raise CheckFailed(f"{call} raised {type(exc).__name__}: {exc}") from None
        if not isinstance(got, (set, frozenset)) or not all(isinstance(p, str) for p in got):
            raise CheckFailed(f"{call} returned {got!r}: it must return a set of str")
        unknown = set(got) - set(POLICIES)
        if unknown:
            raise CheckFailed(
                f"{call} returned {sorted(got)}: {sorted(unknown)} is not one of {list(POLICIES)}"
            )
        want = rclpy_incompatible_policies(pub, sub)
        if set(got) != want:
            extra, missing = sorted(set(got) - want), sorted(want - set(got))
            detail = []
            if missing:
                detail.append(f"{missing} stop(s) this pair from connecting")
            if extra:
                detail.append(f"{extra} do(es) not: a subscription may ask for less than offered")
            raise CheckFailed(
                f"{call} returned {sorted(got)}; rclpy's own check (qos_check_compatible) "
                f"says {sorted(want)}: " + "; ".join(detail) + "."
            )


def qos_fields(qos: QoSProfile) -> dict[str, Any]:
    """Every field of ``qos`` as plain data, which the judge's agent rebuilds the profile
    from in the student's kernel (``rosbook.labs.agent.qos_profile``)."""
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


def _incompatible_in_kernel(
    j: Judgement, function: Student, pairs: Sequence[tuple[QoSProfile, QoSProfile]]
) -> Callable[[QoSProfile, QoSProfile], Any]:
    """The student's ``function`` called in the kernel on every pair of ``pairs`` (the
    profiles sent as ``qos_fields``); a stand-in that gives its answers in turn, as plain
    data, and raises again (by its type's name and message) what it raised."""
    fields = [[qos_fields(pub), qos_fields(sub)] for pub, sub in pairs]
    answers = iter(j.kernel.call("qos_pairs", function.name, fields))

    def answered(pub: QoSProfile, sub: QoSProfile) -> Any:
        answer = next(answers)
        if "raised" in answer:
            raise type(str(answer["raised"]), (Exception,), {})(str(answer["message"]))
        return decode(answer)

    return answered


deferrable(globals())
