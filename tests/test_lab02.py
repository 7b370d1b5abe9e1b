"""Lab 2 graded end to end: fixture submissions for the common QoS mistakes."""

from __future__ import annotations

import html
import re
from pathlib import Path

import nbformat
import pytest

from autograder.check import check, report
from tests.labtools import (
    answered,
    feedback,
    grade,
    lab02_volatile_map_publisher,
    replace_in_answer,
    submit,
    with_round_trip,
)

#: The whole lab graded as a class: minutes (`make test-fast` leaves it out).
pytestmark = pytest.mark.slow

LAB = "lab02_qos"


def reliable_scan_subscription() -> nbformat.NotebookNode:
    return answered(
        LAB, **replace_in_answer(LAB, "scan_subscription", "qos_profile_sensor_data", "10")
    )


def off_by_one_model() -> nbformat.NotebookNode:
    """The queue counts the message in progress: one slot too many."""
    return answered(
        LAB, **replace_in_answer(LAB, "slow_subscriber_model", "== depth:", "== depth + 1:")
    )


def durability_rule_reversed() -> nbformat.NotebookNode:
    fix = replace_in_answer(
        LAB,
        "qos_incompatibilities",
        "sub_deadline > 0 and (pub_deadline == 0 or pub_deadline > sub_deadline)",
        "sub_deadline > 0 and pub_deadline > sub_deadline",
    )
    return answered(LAB, **fix)


@pytest.fixture(scope="module")
def graded(
    tmp_path_factory: pytest.TempPathFactory, round_trip: tuple[dict, Path]
) -> tuple[dict, Path]:
    root = tmp_path_factory.mktemp("submissions")
    submit(root, "volatile_map", LAB, lab02_volatile_map_publisher())
    submit(root, "reliable_scan", LAB, reliable_scan_subscription())
    submit(root, "off_by_one", LAB, off_by_one_model())
    submit(root, "no_deadline_rule", LAB, durability_rule_reversed())
    out = tmp_path_factory.mktemp("out")
    rows = grade(root, out, assignment_id=LAB, workers=2, cell_timeout=20)
    return with_round_trip((rows, out), round_trip, LAB)


def score(graded: tuple[dict, Path], student: str) -> tuple[str, str, str]:
    row = graded[0][(student, LAB)]
    return row["status"], row["score"], row["max_score"]


def test_right_submission_scores_full_marks(graded: tuple[dict, Path]) -> None:
    assert score(graded, "right") == ("ok", "10", "10")


def test_volatile_map_publisher_is_told_to_use_transient_local(graded) -> None:
    assert score(graded, "volatile_map") == ("ok", "7", "10")
    page = feedback(graded[1], "volatile_map", LAB)
    assert "your publisher is RELIABLE, VOLATILE, depth 1" in page
    assert "use durability=DurabilityPolicy.TRANSIENT_LOCAL" in page


def test_reliable_scan_subscription_is_told_it_never_connects(graded) -> None:
    assert score(graded, "reliable_scan") == ("ok", "8", "10")
    page = feedback(graded[1], "reliable_scan", LAB)
    assert "asks for RELIABLE delivery, which a BEST_EFFORT sensor publisher" in page
    assert "Subscribe with qos_profile_sensor_data" in page


def test_off_by_one_model_is_told_its_queue_is_one_too_deep(graded) -> None:
    assert score(graded, "off_by_one") == ("ok", "7", "10")
    page = feedback(graded[1], "off_by_one", LAB)
    assert "predict_processed(2, 1.7, 3, 6) returned [1, 2, 4, 8, 9, 10, 11, 12]" in page
    assert "That is the answer for a queue of depth 4" in page


def test_missing_deadline_rule_is_caught_by_the_hidden_profile_pairs(graded) -> None:
    assert score(graded, "no_deadline_rule") == ("ok", "8", "10")
    page = html.unescape(re.sub(r"<[^>]+>", "", feedback(graded[1], "no_deadline_rule", LAB)))
    assert "no deadline; subscription: RELIABLE, VOLATILE, depth 5, deadline 0.1 s" in page
    assert "rclpy's own check (qos_check_compatible) says ['deadline']" in page


def test_feedback_never_shows_hidden_tests(graded) -> None:
    for student in ("right", "off_by_one", "no_deadline_rule"):
        page = feedback(graded[1], student, LAB)
        assert "BEGIN HIDDEN TESTS" not in page and "MODEL_CASES" not in page


def test_self_check_names_the_failing_visible_checks(tmp_path: Path) -> None:
    path = tmp_path / f"{LAB}.ipynb"
    nbformat.write(reliable_scan_subscription(), path)
    run = check(path, cell_timeout=20)
    passed = {r.grade_id: r.passed for r in run.results}
    assert passed == {
        "test_map_publisher": True,
        "test_scan_subscription": False,
        "test_slow_subscriber_model": True,
        "test_qos_incompatibilities": True,
    }, report(path, run)
