"""Scores come from the judge, not from the student's kernel: attacks graded for real.

Each attack is lab 1's "wrong" submission (only the subscriber is right: 2 points
earned by working code) plus one cell that makes the test cells pass inside the kernel.
Graded with the documented ``python -m autograder grade`` in one class with honest
submissions, none may score more than the 2 points its code earns, and every attack
whose test cells claimed a pass is marked ``tampered`` with the cells named. Labs 2 to
6 are attacked in ``test_trusted_grading_labs.py`` (a file of its own, so that a second
worker grades them meanwhile).
"""

from __future__ import annotations

import csv
import html
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

from autograder.config import ROOT
from tests.labtools import (
    ATTACKS,
    HISTORY_PRINTER,
    LAB01,
    NEUTER,
    SOURCE_PRINTER,
    answered,
    extra_cell,
    feedback,
    grade_id,
    hidden_only_lines,
    lab01_wrong,
    output_text,
    replace_in_answer,
    submit,
)

#: Each case grades attack notebooks with the documented command: out of `make test-fast`.
LAB = LAB01

pytestmark = pytest.mark.slow

#: The attack that ships a package: the submission folder holds its own `rosbook`
#: (the real one, with neutered checks), first on the kernel's sys.path.
SHIPPED = "shipped_rosbook"


def ship_rosbook(root: Path) -> None:
    package = root / SHIPPED / LAB / "rosbook"
    shutil.copytree(ROOT / "rosbook", package, ignore=shutil.ignore_patterns("__pycache__"))
    checks = package / "labs" / "lab01.py"  # what lab 1 imports as `checks`
    checks.write_text(checks.read_text() + "\nimport sys as _s\n_m = _s.modules[__name__]" + NEUTER)


def duplicated_cell() -> nbformat.NotebookNode:
    """JupyterLab's copy of a solution cell keeps its nbgrader metadata."""
    notebook = answered(LAB)
    index = next(
        i
        for i, c in enumerate(notebook.cells)
        if c.metadata.get("nbgrader", {}).get("grade_id") == "counter_subscriber"
    )
    notebook.cells.insert(index + 1, nbformat.from_dict(dict(notebook.cells[index])))
    return notebook


@pytest.fixture(scope="module")
def graded(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, dict[str, str]], Path]:
    root = tmp_path_factory.mktemp("submissions")
    submit(root, "right", LAB, answered(LAB))
    submit(root, "wrong", LAB, lab01_wrong())
    submit(root, "duplicated_cell", LAB, duplicated_cell())
    # rclpy.spin() left at the end of a solution cell: a timer wakes the spin, so the
    # interrupt stops it; a subscription alone never wakes it, and the kernel stays busy.
    spinning = replace_in_answer(
        LAB,
        "counter_publisher",
        "self.count += 1",
        "self.count += 1\n\n\nimport rclpy\nrclpy.spin(CounterPublisher())",
    )
    submit(root, "spin_left_in_cell", LAB, answered(LAB, **spinning))
    stuck = replace_in_answer(
        LAB, "doubler", "2 * msg.data))", "2 * msg.data))\n\n\nimport rclpy\nrclpy.spin(Doubler())"
    )
    submit(root, "spin_stuck_in_cell", LAB, answered(LAB, **stuck))
    for name, source in ATTACKS.items():
        submit(root, name, LAB, extra_cell(lab01_wrong(), source))
    reader = extra_cell(answered(LAB), SOURCE_PRINTER)
    reader.cells.append(nbformat.v4.new_code_cell(HISTORY_PRINTER))
    submit(root, "hidden_source_reader", LAB, reader)
    submit(root, SHIPPED, LAB, lab01_wrong())
    ship_rosbook(root)
    out = tmp_path_factory.mktemp("out")
    done = subprocess.run(
        [sys.executable, "-m", "autograder", "grade", str(root), "--assignment", LAB,
         "--workers", "2", "--timeout", "30", "--out", str(out)],
        capture_output=True, text=True, timeout=3600, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    with open(out / "grades.csv") as f:
        rows = {r["student_id"]: r for r in csv.DictReader(f)}
    return rows, out


def test_honest_submissions_score_as_their_code_earns(graded) -> None:
    rows, _ = graded
    assert (rows["right"]["score"], rows["right"]["status"]) == ("10", "ok")
    assert (rows["wrong"]["score"], rows["wrong"]["status"]) == ("2", "ok")


def test_a_duplicated_solution_cell_is_graded_like_the_original(graded) -> None:
    rows, _ = graded
    assert (rows["duplicated_cell"]["score"], rows["duplicated_cell"]["status"]) == ("10", "ok")


def test_a_spin_left_in_a_cell_costs_only_that_cell_and_is_named(graded) -> None:
    rows, out = graded
    assert (rows["spin_left_in_cell"]["score"], rows["spin_left_in_cell"]["status"]) == (
        "10",
        "timeout",
    )
    assert "interrupted: counter_publisher." in feedback(out, "spin_left_in_cell", LAB)


def test_a_kernel_left_busy_keeps_the_points_earned_before_it(graded) -> None:
    """nbgrader does not abandon the notebook (it used to: 0/10 "error")."""
    rows, out = graded
    r = rows["spin_stuck_in_cell"]
    assert (r["score"], r["status"]) == ("5", "timeout")  # publisher 3 + subscriber 2
    assert "interrupted: doubler" in feedback(out, "spin_stuck_in_cell", LAB)


def test_cells_after_one_that_keeps_the_kernel_busy_are_not_run_and_say_so(graded) -> None:
    """The interrupt never stops that spin: the later cells are not sent to the kernel
    (each would wait out the limit), nor its checks to the judge (which would wait for
    the kernel); each says why, and the student is told which cells did not run."""
    _, out = graded
    page = html.unescape(feedback(out, "spin_stuck_in_cell", LAB))
    assert "30 s after it was interrupted, so these later cells did not run: talker_script" in page
    autograded = nbformat.read(
        out / "autograded" / "spin_stuck_in_cell" / LAB / f"{LAB}.ipynb", as_version=4
    )
    after = autograded.cells[
        next(i for i, c in enumerate(autograded.cells) if grade_id(c) == "doubler") + 1 :
    ]
    shown = {
        grade_id(c): [o.get("evalue", "") for o in c.outputs]
        for c in after
        if c.cell_type == "code"
    }
    assert set(shown) == {"test_doubler", "talker_script", "test_talker_script"}, shown
    for cell, outputs in shown.items():
        assert (
            len(outputs) == 1 and "not run: the kernel was still busy with doubler" in outputs[0]
        ), (
            cell,
            outputs,
        )
    log = (out / "logs" / "spin_stuck_in_cell" / f"{LAB}.log").read_text()
    assert "[judge] test_doubler" not in log and "[judge] test_talker_script" not in log, log


def test_the_kernel_never_gets_a_hidden_test_and_the_lab_still_grades_right(graded) -> None:
    """A student's IPython hooks print every cell's source before and after it runs, and
    a last cell prints the input history: none of them, nor the feedback, shows a line
    of the hidden tests (the kernel gets each test cell as released); the right answer
    still earns every point, hidden checks included (the judge runs them)."""
    rows, out = graded
    r = rows["hidden_source_reader"]
    assert (r["score"], r["status"]) == ("10", "ok"), r
    autograded = out / "autograded" / "hidden_source_reader" / LAB / f"{LAB}.ipynb"
    page = html.unescape(feedback(out, "hidden_source_reader", LAB))
    assert page.count("passed: the grader checked this cell on your code") == 4
    seen = output_text(nbformat.read(autograded, as_version=4)) + page
    assert "POST-RUN:" in seen and "HISTORY:" in seen
    assert "checks.make_node(Doubler)" in seen  # a visible test line: the readers saw tests
    hidden = hidden_only_lines(LAB)
    assert len(hidden) > 20
    assert [line for line in hidden if line in seen] == []


@pytest.mark.parametrize("attack", [*ATTACKS, SHIPPED])
def test_an_attack_in_the_kernel_earns_no_point_its_code_did_not(graded, attack: str) -> None:
    rows, out = graded
    r = rows[attack]
    assert float(r["score"]) <= 2, r  # the wrong submission's code earns 2
    page = feedback(out, attack, LAB)
    if r["status"] == "tampered":
        assert "test_doubler" in page or "Grading code changed" in page, page[:2000]


@pytest.mark.parametrize(
    "attack",
    [
        "input_transformer",
        "pre_run_cell_hook",
        "post_run_cell_hook",
        "run_cell_replaced",
        "importlib",
        "alias",
        "sys_modules",
        "gc",
        "exec_base64",
        "builtins_override",
        SHIPPED,
    ],
)
def test_a_pass_claimed_in_the_kernel_but_not_judged_is_flagged_by_cell(graded, attack) -> None:
    rows, out = graded
    assert rows[attack]["status"] == "tampered"
    page = feedback(out, attack, LAB)
    assert "Checks that passed only inside your notebook" in page
    assert "test_talker_script" in page
