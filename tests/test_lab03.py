"""Lab 3 graded end to end: the usual mistakes with services, actions and parameters."""

from __future__ import annotations

import html
import re
from pathlib import Path

import nbformat
import pytest

from tests.labtools import (
    answered,
    feedback,
    grade,
    replace_in_answer,
    submit,
    with_round_trip,
)

#: The whole lab graded as a class: minutes (`make test-fast` leaves it out).
pytestmark = pytest.mark.slow

LAB = "lab03_services_actions"


def synchronous_call() -> nbformat.NotebookNode:
    """call_trigger waits with the blocking client.call(): nothing spins the node."""
    return answered(
        LAB,
        **replace_in_answer(
            LAB,
            "trigger_client",
            "future = client.call_async(Trigger.Request())",
            "return client.call(Trigger.Request())",
        ),
    )


def wrong() -> nbformat.NotebookNode:
    """Wall-clock time, a cancel that is never accepted, a parameter never declared."""
    fixes = {}
    fixes.update(
        replace_in_answer(
            LAB,
            "clock_server",
            "seconds = self.get_clock().now().nanoseconds / 1e9",
            "import time\n        seconds = time.time()",
        )
    )
    fixes.update(
        replace_in_answer(
            LAB,
            "countdown_action",
            ",\n                                   cancel_callback=self.cancel_callback",
            "",
        )
    )
    rate = replace_in_answer(
        LAB,
        "rate_parameter",
        "self.declare_parameter(\n            'rate_hz', 2.0, "
        "ParameterDescriptor(description='ticks per second, > 0'))",
        "self.rate_hz = 2.0",
    )
    rate["rate_parameter"] = rate["rate_parameter"].replace(
        "1.0 / self.get_parameter('rate_hz').value", "1.0 / self.rate_hz"
    )
    fixes.update(rate)
    return answered(LAB, **fixes)


@pytest.fixture(scope="module")
def graded(
    tmp_path_factory: pytest.TempPathFactory, round_trip: tuple[dict, Path]
) -> tuple[dict, Path]:
    root = tmp_path_factory.mktemp("submissions")
    submit(root, "sync_call", LAB, synchronous_call())
    submit(root, "wrong", LAB, wrong())
    out = tmp_path_factory.mktemp("out")
    rows = grade(root, out, assignment_id=LAB, workers=2, cell_timeout=15)
    return with_round_trip((rows, out), round_trip, LAB, ("right", "untouched"))


def text(graded: tuple[dict, Path], student: str) -> str:
    """The feedback page as a student reads it: no tags, no HTML escapes."""
    page = feedback(graded[1], student, LAB)
    return html.unescape(re.sub(r"<[^>]+>", "", page))


def row(graded: tuple[dict, Path], student: str) -> dict:
    return graded[0][(student, LAB)]


def test_right_submission_scores_full_marks(graded) -> None:
    r = row(graded, "right")
    assert (r["status"], r["score"], r["max_score"]) == ("ok", "10", "10")


def test_untouched_release_scores_zero_cleanly(graded) -> None:
    r = row(graded, "untouched")
    assert (r["status"], r["score"]) == ("ok", "0")
    assert "NotImplementedError" in feedback(graded[1], "untouched", LAB)


def test_synchronous_call_fails_fast_naming_the_deadlock(graded) -> None:
    r = row(graded, "sync_call")
    # The student's own try-it cell hangs on client.call() until the cell timeout;
    # the check itself gives up after its deadline and says why.
    assert (r["status"], r["score"]) == ("timeout", "7")
    page = text(graded, "sync_call")
    # the judge's deadline (a hang guard on a busy machine) is longer than a self-check's
    assert re.search(
        r"call_trigger\(node, 'check_trigger', 2.0\) did not return within \d+ s", page
    )
    assert "deadlock of a synchronous call inside a callback" in page
    assert "client.call_async(request)" in page


def test_wrong_submission_gets_feedback_naming_each_mistake(graded) -> None:
    r = row(graded, "wrong")
    assert (r["status"], r["score"]) == ("ok", "3")  # only call_trigger is right
    page = text(graded, "wrong")
    assert "answered 'It is 17" in page and "when the node's ROS clock read 12.5 s" in page
    assert "not time.time()" in page
    assert "the goal went on to SUCCEEDED" in page and "the cancel was ignored" in page
    assert "node 'rate_publisher' has no parameter 'rate_hz'" in page
    assert "declare it in __init__ with self.declare_parameter('rate_hz', 2.0)" in page


def test_feedback_never_shows_hidden_tests(graded) -> None:
    for student in ("right", "wrong", "sync_call"):
        page = feedback(graded[1], student, LAB)
        assert "BEGIN HIDDEN TESTS" not in page
        assert "slow_trigger" not in page
