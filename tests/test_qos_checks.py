"""rosbook.labs.lab02: lab 2's checks pass the right answers and name each mistake."""

from __future__ import annotations

import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String

from rosbook.demos import qos
from rosbook.labs import lab02 as qos_checks
from rosbook.runtime.session import Session


def map_publisher(durability: DurabilityPolicy):
    def make(node):
        return node.create_publisher(String, "map", QoSProfile(depth=1, durability=durability))

    return make


def test_transient_local_map_reaches_the_late_joiner(session: Session) -> None:
    got = qos_checks.assert_late_joiner_gets_last(
        map_publisher(DurabilityPolicy.TRANSIENT_LOCAL), ["a", "b"]
    )
    assert got == ["b"]


def test_volatile_map_is_told_to_use_transient_local(session: Session) -> None:
    with pytest.raises(AssertionError, match="use durability=DurabilityPolicy.TRANSIENT_LOCAL"):
        qos_checks.assert_late_joiner_gets_last(map_publisher(DurabilityPolicy.VOLATILE), ["a"])


def test_a_function_that_returns_nothing_is_told_to_return_the_publisher(
    session: Session,
) -> None:
    def forgets_return(node):
        node.create_publisher(String, "map", 1)

    with pytest.raises(AssertionError, match="returned NoneType"):
        qos_checks.assert_late_joiner_gets_last(forgets_return, ["a"])


def scan_subscription(qos_profile):
    def make(node, callback):
        return node.create_subscription(LaserScan, "scan", callback, qos_profile)

    return make


def test_sensor_data_subscription_receives_every_scan(session: Session) -> None:
    got = qos_checks.assert_receives_sensor_data(scan_subscription(qos_profile_sensor_data), 4)
    assert [list(m.ranges) for m in got] == [list(qos_checks.make_scan(i).ranges) for i in range(4)]


def test_reliable_scan_subscription_is_told_it_never_connects(session: Session) -> None:
    with pytest.raises(AssertionError, match="asks for RELIABLE delivery"):
        qos_checks.assert_receives_sensor_data(scan_subscription(10), 2)


def test_model_check_names_a_queue_one_too_deep() -> None:
    def one_too_deep(hz, work, depth, duration):
        return qos.predict_processed(hz, work, depth + 1, duration)

    qos_checks.assert_model_matches(qos.predict_processed, qos_checks.MODEL_CASES)
    with pytest.raises(AssertionError, match="the answer for a queue of depth 4"):
        qos_checks.assert_model_matches(one_too_deep, [(2, 1.7, 3, 6)])


def test_model_check_names_a_missing_drain() -> None:
    def no_drain(hz, work, depth, duration):
        records = qos.model_records(hz, work, depth, duration)
        return [r.index for r in records if r.received is not None and r.received < duration]

    with pytest.raises(AssertionError, match="still drains its queue"):
        qos_checks.assert_model_matches(no_drain, [(2, 1.7, 3, 6)])


def test_a_model_the_kernel_could_only_describe_is_named_by_its_type() -> None:
    """Graded, what the student's function returned crosses as plain data: a value that
    is not (a generator) arrives as its type and repr, and is named as a local run names
    it."""
    from rosbook.labs.remote import Unreadable

    def generator(hz, work, depth, duration):
        return (k for k in (1, 2))

    def described(hz, work, depth, duration):
        return Unreadable("generator", "<generator object <genexpr> at 0x7f>")

    said = []
    for predict in (generator, described):
        with pytest.raises(AssertionError) as failed:
            qos_checks.assert_model_matches(predict, [(2, 1.7, 3, 6)])
        said.append(str(failed.value))
    assert said == ["predict_processed(2, 1.7, 3, 6) returned generator, not a list of ints"] * 2


def test_compatibility_check_agrees_with_rclpy_on_every_profile_pair() -> None:
    profiles = qos_checks.qos_profiles()
    pairs = [(p, s) for p in profiles for s in profiles]
    qos_checks.assert_incompatibilities_match(qos.incompatible_policies, pairs)

    def reliability_only(pub, sub):
        return qos.incompatible_policies(pub, sub) & {"reliability"}

    best_effort = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
    with pytest.raises(AssertionError, match=r"says \['durability'\]"):
        qos_checks.assert_incompatibilities_match(
            reliability_only,
            [(best_effort, best_effort), (QoSProfile(depth=1), qos_checks.LATE_JOINER_QOS)],
        )
