"""Lab 8 graded end to end: a student's tests are run against the correct wall stopper
and seeded bugs, and the feedback names each bug they missed by what it does."""

from __future__ import annotations

import html
from pathlib import Path

import nbformat
import pytest

from autograder.course import strip_markers
from rosbook.labs import lab08
from rosbook.labs.probes import CheckFailed, TimedOut
from rosbook.labs.wall_stopper import BUGS
from tests.labtools import (
    ATTACKS,
    answered,
    extra_cell,
    feedback,
    grade,
    notebook_path,
    replace_in_answer,
    solution_answers,
    submit,
    with_round_trip,
)

LAB = "lab08_testing"
TASK = "wall_stopper_tests"


def with_tests(*changes: tuple[str, str]) -> nbformat.NotebookNode:
    """The solution's test file with each ``old -> new`` replaced."""
    source = strip_markers(solution_answers(LAB)[TASK])
    for old, new in changes:
        assert old in source, old
        source = source.replace(old, new)
    return answered(LAB, **{TASK: source})


def unit_tests_only() -> nbformat.NotebookNode:
    """The solution's test file without its node test: only ``forward_speed`` is tested."""
    source = replace_in_answer(LAB, TASK, "", "")[TASK]
    return answered(LAB, **{TASK: source[: source.index("@pytest.fixture")]})


@pytest.fixture(scope="module")
def graded(
    tmp_path_factory: pytest.TempPathFactory, round_trip: tuple[dict, Path]
) -> tuple[dict, Path]:
    root = tmp_path_factory.mktemp("submissions")
    weak = with_tests(
        ("ranges(0.5), -math.pi", "ranges(0.49), -math.pi"),
        ("parameter_overrides=[Parameter('stop_at', value=1.0)]", "parameter_overrides=[]"),
        ("assert answer(0.8) == 0.0", "assert answer(0.4) == 0.0"),
    )
    submit(root, "weak_tests", LAB, weak)
    strict = with_tests(
        ("assert forward_speed(ranges(0.5), -math.pi, STEP, 0.3, 0.5) == 0.0",
         "assert forward_speed(ranges(0.5), -math.pi, STEP, 0.3, 0.5) == 0.3"),
    )  # fmt: skip
    submit(root, "wrong_expectation", LAB, strict)
    submit(root, "unit_tests_only", LAB, unit_tests_only())
    submit(root, "hostile", LAB, extra_cell(answered(LAB), ATTACKS["input_transformer"]))
    out = tmp_path_factory.mktemp("out")
    # no submission here hangs: a generous cell guard, so a loaded machine never times out
    rows = grade(root, out, assignment_id=LAB, workers=2, cell_timeout=600)
    return with_round_trip((rows, out), round_trip, LAB, ("right", "untouched"))


def result(graded: tuple[dict, Path], student: str) -> tuple[dict, str]:
    rows, out = graded
    return rows[(student, LAB)], html.unescape(feedback(out, student, LAB))


def test_right_tests_score_full_marks(graded: tuple[dict, Path]) -> None:
    row, _ = result(graded, "right")
    assert (row["status"], row["score"], row["max_score"]) == ("ok", "10", "10")


def test_the_release_scores_nothing_and_says_the_file_does_not_run(
    graded: tuple[dict, Path],
) -> None:
    row, page = result(graded, "untouched")
    assert (row["status"], row["score"]) == ("ok", "0")
    assert "pytest could not run test_wall_stopper.py (exit code 2)" in page


def test_tests_that_miss_hidden_bugs_are_told_what_the_bugs_do(graded: tuple[dict, Path]) -> None:
    row, page = result(graded, "weak_tests")
    assert (row["status"], row["score"]) == ("ok", "2")
    assert f"your tests passed on {BUGS['stops_late']}. Add a test that fails on it." in page
    assert f"your tests passed on {BUGS['ignores_stop_at']}. Add a test" in page


def test_a_test_that_fails_on_the_correct_node_is_named_and_earns_nothing(
    graded: tuple[dict, Path],
) -> None:
    row, page = result(graded, "wrong_expectation")
    assert (row["status"], row["score"]) == ("ok", "0")
    assert (
        "your tests must all pass on a correct wall stopper, and these failed: "
        "test_stops_at_exactly_the_stop_distance"
    ) in page


def test_unit_tests_alone_miss_the_node_bugs(graded: tuple[dict, Path]) -> None:
    row, page = result(graded, "unit_tests_only")
    assert (row["status"], row["score"]) == ("ok", "6")
    assert f"your tests passed on {BUGS['wrong_topic']}." in page


def test_cells_turned_into_pass_in_the_kernel_score_nothing(graded: tuple[dict, Path]) -> None:
    """The kernel runs every cell as ``pass``: no test file is written, and the judge,
    which runs the test cells itself, gives no point for one; the passes the kernel
    claimed are flagged."""
    row, page = result(graded, "hostile")
    assert (row["status"], row["score"]) == ("tampered", "0")
    assert "Checks that passed only inside your notebook" in page
    assert "test_wall_stopper.py does not exist" in page


def test_feedback_never_shows_hidden_tests(graded: tuple[dict, Path]) -> None:
    for student in ("right", "weak_tests", "unit_tests_only"):
        _, page = result(graded, student)
        assert "BEGIN HIDDEN TESTS" not in page
        assert "'stops_late', 'wide_cone'" not in page and "['ignores_stop_at']" not in page


def test_every_seeded_bug_is_tried_by_a_test_cell_of_the_lab() -> None:
    """A bug added to ``wall_stopper.BUGS`` is tried on students' tests, visibly or hidden."""
    source = nbformat.read(notebook_path(LAB, released=False), 4)
    cells = "".join(c.source for c in source.cells if c.metadata.get("nbgrader", {}).get("grade"))
    assert [bug for bug in BUGS if repr(bug) not in cells] == []


def test_a_test_file_that_exits_before_pytest_reports_earns_no_pass(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Exit code 0 with no test passed (the file ends the process at import) is no pass."""
    (tmp_path / lab08.TEST_FILE).write_text("import os\n\nos._exit(0)\n")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(CheckFailed, match="pytest found no tests in test_wall_stopper.py"):
        lab08.assert_passes_on_correct()


def test_a_test_that_hangs_is_a_timeout_never_wrong(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    hangs = "import threading\n\n\ndef test_waits_forever():\n    threading.Event().wait()\n"
    (tmp_path / lab08.TEST_FILE).write_text(hangs)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(lab08, "RUN_GUARD_S", 5.0)
    with pytest.raises(TimedOut, match="had not finished after 5 s"):
        lab08.run_tests(bug="never_stops")
