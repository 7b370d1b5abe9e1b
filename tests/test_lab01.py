"""Lab 1 graded end to end: fixture submissions for each kind of student behaviour."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

from autograder.check import check, report
from tests.labtools import (
    LAB01,
    answered,
    extra_cell,
    feedback,
    grade,
    lab01_wrong,
    live_marked_processes,
    notebook_path,
    replace_in_answer,
    submit,
    with_cell,
    with_round_trip,
)

CELL_TIMEOUT_S = 30
LAB = LAB01

OLD_MAIN = """    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.shutdown()"""


@pytest.fixture(scope="module")
def graded(
    tmp_path_factory: pytest.TempPathFactory, round_trip: tuple[dict, Path]
) -> tuple[dict, Path]:
    root = tmp_path_factory.mktemp("submissions")
    right = answered(LAB)  # the base of "tampered"; "right" is the round trip's row
    submit(root, "wrong", LAB, lab01_wrong())
    submit(root, "tampered", LAB, with_cell(right, "test_doubler", "pass"))
    cheat = "checks.assert_sequence = lambda *args, **kwargs: None  # make every check pass"
    submit(root, "meddling", LAB, extra_cell(lab01_wrong(), cheat))
    submit(root, "looping", LAB, extra_cell(answered(LAB), "while True:\n    pass"))
    submit(root, "exiting", LAB, extra_cell(answered(LAB), "import os\nos._exit(0)"))
    submit(root, "broken", LAB, '{"cells": [ this is not JSON')
    submit(root, "empty_folder", LAB, None)
    (root / "no_folder").mkdir()
    out = tmp_path_factory.mktemp("out")
    # The limit that stops the endless cell; generous, so that correct cells finish in
    # it on a busy machine.
    rows = grade(root, out, assignment_id=LAB, workers=2, cell_timeout=CELL_TIMEOUT_S)
    return with_round_trip((rows, out), round_trip, LAB)


def row(graded: tuple[dict, Path], student: str) -> dict:
    return graded[0][(student, LAB)]


def test_every_student_gets_a_row_and_a_feedback_page(graded: tuple[dict, Path]) -> None:
    rows, out = graded
    students = {
        "right",
        "wrong",
        "tampered",
        "meddling",
        "looping",
        "exiting",
        "broken",
        "empty_folder",
        "no_folder",
    }
    assert {s for s, _ in rows} == students
    for student in students:
        assert feedback(out, student, LAB).startswith(("<!DOCTYPE html>", "<html", "\n<!DOCTYPE"))
    header = (out / "grades.csv").read_text().splitlines()[0]
    assert header == "student_id,assignment_id,score,max_score,status"


def test_right_submission_scores_full_marks(graded: tuple[dict, Path]) -> None:
    assert row(graded, "right")["status"] == "ok"
    assert row(graded, "right")["score"] == row(graded, "right")["max_score"] == "10"


def test_wrong_submission_gets_feedback_naming_each_mistake(graded: tuple[dict, Path]) -> None:
    r = row(graded, "wrong")
    assert (r["status"], r["score"]) == ("ok", "2")  # only the subscriber is right
    page = feedback(graded[1], "wrong", LAB)
    assert "has no publisher on /counter" in page and "/count (std_msgs/msg/Int64)" in page
    assert "expected [2, 4, 6], got [3, 6, 9]" in page
    assert "did not exit cleanly on Ctrl-C" in page and "ExternalShutdownException" in page


def test_feedback_shows_the_judges_verdict_not_the_deferral(graded) -> None:
    """The judged cells ran deferred in the kernel (their checks raised at once, the
    judge had decided them): each shows the judge's verdict instead."""
    right, wrong = feedback(graded[1], "right", LAB), feedback(graded[1], "wrong", LAB)
    for page in (right, wrong):
        assert "CheckDeferred" not in page and "the grader checks this cell" not in page
    assert right.count("passed: the grader checked this cell on your code") == 4
    assert wrong.count("passed: the grader checked this cell on your code") == 1
    assert "CheckFailed: " in wrong


def test_feedback_never_shows_hidden_tests(graded: tuple[dict, Path]) -> None:
    for student in ("right", "wrong", "tampered"):
        page = feedback(graded[1], student, LAB)
        assert "BEGIN HIDDEN TESTS" not in page
        assert "values = [7, -2, 0, 2**40]" not in page
        assert "Traceback (most recent call last)" not in page or student == "right"


def test_changed_locked_cell_is_graded_with_the_original_and_marked(graded) -> None:
    r = row(graded, "tampered")
    assert (r["status"], r["score"]) == ("tampered", "10")
    assert "test_doubler" in feedback(graded[1], "tampered", LAB)


def test_a_cell_that_changes_the_checks_is_marked_tampered_and_named(graded) -> None:
    r = row(graded, "meddling")
    assert r["status"] == "tampered"
    page = feedback(graded[1], "meddling", LAB)
    assert "Grading code changed" in page
    assert "cell 3, line 1: changes checks.assert_sequence" in page


def test_endless_student_cell_is_interrupted_and_the_rest_graded(graded) -> None:
    r = row(graded, "looping")
    assert (r["status"], r["score"]) == ("timeout", "10")
    assert f"ran longer than {CELL_TIMEOUT_S} s" in feedback(graded[1], "looping", LAB)


def test_killed_kernel_is_an_error_naming_the_cell(graded) -> None:
    r = row(graded, "exiting")
    assert (r["status"], r["score"], r["max_score"]) == ("error", "0", "10")
    assert "os._exit(0)" in feedback(graded[1], "exiting", LAB)


def test_invalid_json_and_missing_notebooks(graded) -> None:
    assert row(graded, "broken")["status"] == "error"
    assert "is not a valid notebook" in feedback(graded[1], "broken", LAB)
    for student in ("empty_folder", "no_folder"):
        assert (row(graded, student)["status"], row(graded, student)["score"]) == ("missing", "0")


def test_grading_leaves_no_process_behind(graded) -> None:
    assert live_marked_processes() == []


def test_self_check_reports_each_visible_check(tmp_path: Path) -> None:
    path = tmp_path / f"{LAB}.ipynb"
    nbformat.write(lab01_wrong(), path)
    run = check(path, cell_timeout=20)
    text = report(path, run)
    passed = {r.grade_id: r.passed for r in run.results}
    assert passed == {
        "test_counter_publisher": False,
        "test_counter_subscriber": True,
        "test_doubler": False,
        "test_talker_script": False,
    }, text
    assert "has no publisher on /counter" in text
    assert run.changed == []


@pytest.mark.slow
def test_self_check_command_passes_on_the_solution_and_prints_only_its_report(
    tmp_path: Path,
) -> None:
    path = tmp_path / f"{LAB}.ipynb"
    shutil.copy(notebook_path(LAB), path)
    nbformat.write(answered(LAB), path)
    done = subprocess.run(
        [sys.executable, "-m", "autograder", "check", str(path), "--timeout", "20"],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    report_lines = [ln for ln in done.stdout.splitlines() if ln.startswith(f"{LAB}.ipynb:")]
    assert report_lines == [
        f"{LAB}.ipynb: 4 of 4 visible checks pass (hidden checks run when the lab is graded)"
    ], done.stdout
    # kernels run over Unix sockets (autograder/kernels.py): no TCP port race, and no
    # "Kernel is running over TCP without encryption" warning on the student's terminal
    assert done.stderr == "", done.stderr


def test_a_grader_started_with_ctrl_c_ignored_judges_ctrl_c_as_a_terminal_would(
    tmp_path: Path,
) -> None:
    """A shell starts a background job (`nohup python -m autograder grade ... &` in a
    script) with SIGINT ignored, and what it starts inherits that: rclpy then turns the
    checks' Ctrl-C into ExternalShutdownException, and a talker that stops cleanly on
    Ctrl-C in a terminal (it catches KeyboardInterrupt) lost its points."""
    main = replace_in_answer(
        LAB,
        "talker_script",
        "except (KeyboardInterrupt, ExternalShutdownException):",
        "except KeyboardInterrupt:",
    )
    submit(tmp_path / "in", "background", LAB, answered(LAB, **main))
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        rows = grade(tmp_path / "in", tmp_path / "out", assignment_id=LAB, workers=1)
    finally:
        signal.signal(signal.SIGINT, previous)
    got = rows[("background", LAB)]
    assert (got["status"], got["score"]) == ("ok", "10"), feedback(
        tmp_path / "out", "background", LAB
    )[-3000:]
