"""rosbook.demos.qos: the KEEP_LAST model, the measured delivery scenarios, compatibility."""

from __future__ import annotations

import itertools
import json
import subprocess
import sys

import pytest
from rclpy.duration import Duration
from rclpy.qos import (
    DurabilityPolicy,
    LivelinessPolicy,
    QoSCompatibility,
    QoSProfile,
    ReliabilityPolicy,
    qos_check_compatible,
    qos_profile_sensor_data,
)

from rosbook.demos import qos
from rosbook.runtime.session import Session
from tests.slowdown import slow_machine


def test_model_processes_1_2_5_9_for_the_slow_subscriber() -> None:
    assert qos.predict_processed(2, 1.7, 3, 6) == [1, 2, 5, 9, 10, 11, 12]
    assert qos.predict_processed(2, 1.7, 3, 4) == [1, 2, 5, 6, 7, 8]


def test_model_drops_the_oldest_when_a_message_arrives_at_a_full_queue() -> None:
    records = qos.model_records(2, 1.7, 3, 6)
    assert qos.dropped_indices(records) == [3, 4, 6, 7, 8]
    assert [records[i - 1].dropped for i in (3, 4)] == [2.5, 3.0]  # at msg6's and msg7's arrival
    assert qos.max_queue(records) == 3


def test_model_edge_cases() -> None:
    assert qos.predict_processed(2, 0.1, 3, 6) == list(range(1, 13))
    assert qos.predict_processed(2, 1.7, 3, 0) == []
    assert qos.predict_processed(2, 1.7, 1, 6) == [1, 4, 7, 11, 12]
    assert qos.predict_processed(1, 5, 100, 4) == [1, 2, 3, 4]  # deep queue: nothing lost
    # a finish and an arrival at the same instant: the finish comes first
    assert qos.predict_processed(2, 1.5, 1, 3) == [1, 3, 6]
    assert qos.predict_processed(10, 0.3, 2, 1) == [1, 2, 5, 8, 9, 10]
    with pytest.raises(ValueError):
        qos.predict_processed(2, 1.0, 0, 3)


def test_publish_times_stop_before_the_duration() -> None:
    assert qos.publish_times(2, 2.0) == [0, 0.5, 1, 1.5]
    assert len(qos.publish_times(3, 1.0)) == 3
    assert len(qos.publish_times(10, 0.3)) == 3


@pytest.mark.parametrize("callback_s", [0.1, 1.7])
def test_measured_delivery_on_sim_time_equals_the_model(callback_s: float) -> None:
    run = qos.run_delivery(callback_s)
    expected = qos.model_records(2, callback_s, 3, 6)
    assert qos.timeline_differences(run.records, expected) == []
    # How much faster than real time is a benchmark figure (benchmarks/bench_qos.py).


@pytest.mark.parametrize(
    ("callback_s", "depth", "duration_s"),
    [
        pytest.param(0.1, 3, 6.0, id="fast"),
        # callbacks longer than the period: slow tier (the model is checked by the others)
        pytest.param(1.7, 3, 6.0, id="slow", marks=pytest.mark.slow),
        pytest.param(1.5, 1, 3.0, id="finish_and_arrival_at_once"),
    ],
)
def test_measured_delivery_equals_the_model_in_every_run(
    callback_s: float, depth: int, duration_s: float
) -> None:
    """The same table every time: each step, the subscriber follows the clock (and a
    callback that ends at that instant ends) before the publisher's timer fires."""
    expected = qos.model_records(2, callback_s, depth, duration_s)
    for _ in range(8):
        run = qos.run_delivery(callback_s, depth=depth, duration_s=duration_s)
        assert qos.timeline_differences(run.records, expected) == []


def test_fast_subscriber_never_queues_more_than_one() -> None:
    run = qos.run_delivery(0.1)
    assert run.dropped == [] and qos.max_queue(run.records) == 1


def test_measured_run_can_stop_at_a_horizon() -> None:
    run = qos.run_delivery(1.7, horizon_s=4.0)
    assert (
        qos.timeline_differences(run.records, qos.until(qos.model_records(2, 1.7, 3, 6), 4.0)) == []
    )
    assert run.processed == [1, 2, 5]


def test_impossible_events_are_only_what_no_load_can_cause() -> None:
    """The chapter's wall-time run asserts these, not the simulated table: a late wake-up
    (here: a callback that ends at 1.9 s instead of 1.7 s) changes which messages are
    processed, but never breaks them."""
    assert qos.impossible_events(qos.model_records(2, 1.7, 3, 6), 1.7) == []
    late = qos.model_records(2, 1.9, 3, 6)
    assert qos.processed_indices(late) != qos.predict_processed(2, 1.7, 3, 6)
    assert qos.impossible_events(late, 1.7) == []

    assert qos.impossible_events(qos.model_records(2, 1.5, 3, 6), 1.7)[0] == (
        "msg1 was processed in 1.500 s, less than the callback's 1.7 s"
    )
    swapped = qos.model_records(2, 1.7, 3, 6)
    swapped[1].received, swapped[4].received = swapped[4].received, swapped[1].received
    assert "messages taken out of order: [1, 5, 2, 9, 10, 11, 12]" in qos.impossible_events(
        swapped, 1.7
    )
    overlapping = qos.model_records(2, 1.7, 3, 6)
    overlapping[1].received = 1.0
    assert "msg2 was taken while msg1 was worked on" in qos.impossible_events(overlapping, 1.7)
    skipped = qos.model_records(2, 1.7, 3, 6)
    skipped[0].received = skipped[0].processed = None
    assert "msg1 was not the first message taken" in qos.impossible_events(skipped, 1.7)


#: The chapter's wall-time run, in a process of its own: its clock, whether it processed
#: anything, and the events it shows that cannot happen.
WALL_TIME_RUN = """
import json
from rosbook.demos import qos
run = qos.run_delivery(1.7, sim_time=False, horizon_s=6.0)
print(json.dumps([run.clock, bool(run.processed), qos.impossible_events(run.records, 1.7)]))
"""


@pytest.mark.slow
def test_a_wall_time_run_on_a_slow_machine_shows_no_impossible_event() -> None:
    """The chapter's wall-time run on a slow machine (tests/slowdown.py): what it asserts
    holds (its table may differ from the simulated one, and the chapter says so)."""
    with slow_machine() as inside:
        done = subprocess.run(
            [sys.executable, "-c", WALL_TIME_RUN],
            preexec_fn=inside,
            capture_output=True,
            text=True,
            timeout=600,
        )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.splitlines()[-1]) == ["wall", True, []], done.stdout


def test_late_joiner_gets_nothing_when_volatile_and_the_last_depth_when_transient_local() -> None:
    volatile = qos.run_late_joiner(DurabilityPolicy.VOLATILE)
    assert volatile.processed == [] and volatile.dropped == [1, 2, 3, 4]
    transient = qos.run_late_joiner(DurabilityPolicy.TRANSIENT_LOCAL)
    assert transient.processed == [2, 3, 4] and transient.dropped == [1]
    assert [r.received for r in transient.records[1:]] == [2.5, 2.5, 2.5]
    volatile_joiner = qos.run_late_joiner(
        DurabilityPolicy.TRANSIENT_LOCAL, joiner_durability=DurabilityPolicy.VOLATILE
    )
    assert volatile_joiner.processed == [] and volatile_joiner.dropped == [1, 2, 3, 4]


def test_table_and_plot_come_from_the_records() -> None:
    records = qos.model_records(2, 1.7, 3, 4)
    table = qos.table_markdown(records)
    assert table.splitlines()[0].startswith("| message | published")
    assert "| msg3 | 1.0 | – | – | 2.5 | – |" in table
    html = qos.table_html(records)
    assert html.count("<tr>") == 9 and "<td>msg3</td><td>1.0</td><td>–</td>" in html
    ax = qos.plot_timeline(records, "slow")
    assert len(ax.get_yticks()) == 8


def profiles() -> list[QoSProfile]:
    return [
        QoSProfile(
            depth=5,
            reliability=r,
            durability=d,
            deadline=Duration(seconds=dl),
            liveliness=LivelinessPolicy.AUTOMATIC,
        )
        for r in (ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT)
        for d in (DurabilityPolicy.VOLATILE, DurabilityPolicy.TRANSIENT_LOCAL)
        for dl in (0, 0.1, 1.0)
    ]


def test_incompatible_policies_agree_with_rclpys_own_check() -> None:
    for pub, sub in itertools.product(profiles(), profiles()):
        ours = qos.incompatible_policies(pub, sub)
        assert ours == qos.rclpy_incompatible_policies(pub, sub), (pub, sub)
        verdict, reason = qos_check_compatible(pub, sub)
        assert (verdict == QoSCompatibility.ERROR) == bool(ours), reason


def test_sensor_data_publisher_and_default_subscription_do_not_connect() -> None:
    assert qos.incompatible_policies(qos_profile_sensor_data, QoSProfile(depth=10)) == {
        "reliability"
    }
    assert qos.incompatible_policies(QoSProfile(depth=10), qos_profile_sensor_data) == set()


def test_incompatible_pair_raises_events_on_both_sides_and_receives_nothing(
    session: Session,
) -> None:
    best_effort = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
    report = qos.watch_incompatibility(best_effort, QoSProfile(depth=5))
    assert report.publisher_events and report.subscription_events
    assert set(report.publisher_events) == set(report.subscription_events) == {"RELIABILITY"}
    assert (report.connected, report.received) == (False, 0)
    fine = qos.watch_incompatibility(QoSProfile(depth=5), best_effort)
    assert (fine.connected, fine.received, fine.publisher_events) == (True, 5, [])
