"""Lab 8 graded end to end: a student's tests are run against the correct wall stopper
and seeded bugs, and the feedback names each bug they missed by what it does. A test
file that finds out which node it runs on, instead of testing what it does, earns no
more than one that tests nothing."""

from __future__ import annotations

import html
import math
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

from autograder.course import strip_markers
from rosbook.labs import lab08, wall_stopper
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


#: A test file that tests nothing: it passes on every node (what it earns is the floor).
EMPTY = """\
from wall_stopper import WallStopper, forward_speed


def test_the_node_imports():
    assert callable(forward_speed) and WallStopper.__name__ == 'WallStopper'
"""

#: A test file that fails when anything in its process names a bug (the module's state,
#: its arguments, environment or input): it "catches" bugs it never tests.
READS_STATE = """\
import os
import sys

import wall_stopper
from rosbook.labs.wall_stopper import BUGS
from wall_stopper import WallStopper, forward_speed


def test_no_bug_is_seeded():
    try:
        given = sys.__stdin__.read()
    except (OSError, ValueError):
        given = ''
    seen = repr(sys.argv) + repr(dict(os.environ)) + given
    assert getattr(wall_stopper, '_bug', None) is None
    assert [bug for bug in BUGS if bug in seen] == []
"""

#: A test file that fails unless the node's bytecode is the correct one's, which it
#: makes from what the release holds.
FINGERPRINTS = """\
import types

import wall_stopper
from rosbook.labs.wall_stopper import variant
from wall_stopper import WallStopper, forward_speed


def code_of(namespace):
    found = []
    for value in (namespace['forward_speed'], *vars(namespace['WallStopper']).values()):
        if isinstance(value, types.FunctionType):
            found.append((value.__qualname__, value.__code__.co_code, value.__code__.co_consts))
    return found


def test_the_node_is_the_correct_one():
    correct = {}
    exec(variant(), correct)
    assert code_of(vars(wall_stopper)) == code_of(correct)
"""


def with_test_file(source: str) -> nbformat.NotebookNode:
    """The release with ``source`` as its test file."""
    return answered(LAB, **{TASK: f"%%writefile {lab08.TEST_FILE}\n{source}"})


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
    submit(root, "empty_tests", LAB, with_test_file(EMPTY))
    submit(root, "reads_state", LAB, with_test_file(READS_STATE))
    submit(root, "fingerprints", LAB, with_test_file(FINGERPRINTS))
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


def test_a_test_file_that_tests_nothing_earns_only_the_pass_on_correct(
    graded: tuple[dict, Path],
) -> None:
    row, page = result(graded, "empty_tests")
    assert (row["status"], row["score"]) == ("ok", "2")
    assert f"your tests passed on {BUGS['never_stops']}" in page


@pytest.mark.parametrize("student", ["reads_state", "fingerprints"])
def test_a_test_file_that_finds_out_which_node_it_runs_on_earns_no_more_than_an_empty_one(
    graded: tuple[dict, Path], student: str
) -> None:
    """Nothing in the test process names the bug, and the hidden tests also run a
    correct node written differently, which a file that recognises the code fails on.
    (The fingerprinting file's ``exec`` also has it marked tampered, for a person.)"""
    row, _ = result(graded, student)
    empty, _ = result(graded, "empty_tests")
    assert row["status"] in ("ok", "tampered") and int(row["score"]) <= int(empty["score"])


def test_a_fingerprinting_test_file_is_told_it_fails_on_a_correct_node(
    graded: tuple[dict, Path],
) -> None:
    _, page = result(graded, "fingerprints")
    assert (
        "your tests must all pass on a correct wall stopper written differently, and these "
        "failed: test_the_node_is_the_correct_one"
    ) in page


def test_feedback_never_shows_hidden_tests(graded: tuple[dict, Path]) -> None:
    for student in ("right", "weak_tests", "unit_tests_only"):
        _, page = result(graded, student)
        assert "BEGIN HIDDEN TESTS" not in page
        assert "'stops_late', 'wide_cone'" not in page and "['ignores_stop_at']" not in page
        assert "rewrite=" not in page


def test_every_seeded_bug_is_tried_by_a_test_cell_of_the_lab() -> None:
    """A bug added to ``wall_stopper.BUGS`` is tried on students' tests, visibly or hidden."""
    source = nbformat.read(notebook_path(LAB, released=False), 4)
    cells = "".join(c.source for c in source.cells if c.metadata.get("nbgrader", {}).get("grade"))
    assert [bug for bug in BUGS if repr(bug) not in cells] == []


def test_a_test_file_that_exits_before_pytest_reports_earns_no_pass(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Exit code 0 before pytest returned (the file ends the process at import) is no pass."""
    (tmp_path / lab08.TEST_FILE).write_text("import os\n\nos._exit(0)\n")
    monkeypatch.chdir(tmp_path)
    said = "pytest did not finish its run of test_wall_stopper.py on a correct wall stopper: "
    with pytest.raises(CheckFailed, match=f"{said}the process ended \\(exit code 0\\)"):
        lab08.assert_passes_on_correct()


def test_a_runs_verdict_is_what_pytest_returned_not_the_exit_code_the_judge_was_told() -> None:
    """On a loaded machine the judge was told exit code 0 for a sandboxed run whose
    pytest had returned 1 ("1 failed, 5 passed"): the unit-tests-only class scored 2 for 6.
    The verdict is the process's last line, what ``pytest.main`` returned."""
    assert lab08.finished(f"1 failed, 5 passed\n\n{lab08.FINISHED}1\n") == (
        lab08.FAILED,
        "1 failed, 5 passed\n",
    )
    assert lab08.finished("1 failed, 5 passed\n")[0] is None


def test_a_test_that_hangs_is_a_timeout_never_wrong(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    hangs = "import threading\n\n\ndef test_waits_forever():\n    threading.Event().wait()\n"
    (tmp_path / lab08.TEST_FILE).write_text(hangs)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(lab08, "RUN_GUARD_S", 5.0)
    with pytest.raises(TimedOut, match="had not finished after 5 s"):
        lab08.run_tests(bug="never_stops")


@pytest.mark.parametrize("bug", [None, *BUGS])
def test_no_variant_of_the_node_names_its_bug(bug: str | None) -> None:
    """The module under test holds the variant's code only: no bug's name, no decision."""
    for rewrite in (None, 1):
        source = wall_stopper.variant(bug, rewrite)
        assert "_bug" not in source and [b for b in BUGS if b in source] == []
        module = lab08.module_under_test(source)
        assert not hasattr(module, "BUGS") and not hasattr(module, "variant")


def test_a_rewritten_correct_node_is_other_code_with_the_same_answers() -> None:
    correct = lab08.module_under_test(wall_stopper.variant())
    assert wall_stopper.variant(rewrite=58231) != wall_stopper.variant()
    for seed in range(20):
        other = lab08.module_under_test(wall_stopper.variant(rewrite=seed))
        assert other.forward_speed.__code__.co_code != correct.forward_speed.__code__.co_code
        for ranges in ([], [0.5] * 21, [3.0] * 10 + [0.49] + [3.0] * 10, [0.2] + [3.0] * 20):
            for step in (math.radians(1), math.radians(5)):
                for stop_at in (0.49, 0.5, 1.0):
                    args = (ranges, -10 * step, step, 0.3, stop_at)
                    assert other.forward_speed(*args) == correct.forward_speed(*args), args


def test_the_process_under_test_says_what_it_got_and_its_tests_read_nothing_more(
    tmp_path: Path,
) -> None:
    """Its first line is the digest of the module it got on stdin; by then stdin is read
    to its end and closed, so a test reading it finds nothing."""
    test = "import sys\n\n\ndef test_stdin_is_empty():\n    assert sys.__stdin__.read() == ''\n"
    (tmp_path / lab08.TEST_FILE).write_text(test)
    source = wall_stopper.variant("never_stops")
    run = subprocess.run(
        [sys.executable, "-I", "-m", "rosbook.labs.lab08", lab08.TEST_FILE],
        input=source,
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=lab08.RUN_GUARD_S,
    )
    assert run.stdout.splitlines()[0] == lab08.received(source)
    assert run.stdout.splitlines()[-1] == f"{lab08.FINISHED}{lab08.PASSED}", run.stdout
