"""Instructor CI for every lab: labs/ is generated from solutions/, solutions score full
marks, released labs score zero without breaking the grader.

A solution is graded as a student who solved the lab submits it: the release with every
solution cell answered as in solutions/ (the ``round_trip`` fixture, graded once per test
run; each lab's ``test_labNN.py`` reads the same rows beside its own class)."""

from __future__ import annotations

import json
from pathlib import Path

import nbformat
import pytest

from autograder.config import LABS, lab_ids
from autograder.course import release_lab

LABS_NOW = lab_ids()


def normalized(path: Path) -> dict:
    return json.loads(json.dumps(nbformat.read(path, as_version=4), sort_keys=True))


@pytest.mark.slow
@pytest.mark.parametrize("lab", LABS_NOW)
def test_released_lab_is_exactly_what_solutions_generate(lab: str, tmp_path: Path) -> None:
    generated = release_lab(lab, tmp_path / "course", labs_dir=tmp_path / "labs")
    committed = LABS / lab
    assert sorted(p.name for p in generated.iterdir()) == sorted(
        p.name for p in committed.iterdir() if not p.name.endswith(".py")
    ), "labs/ holds other files than generate_assignment makes: run `make labs`"
    for path in generated.iterdir():
        assert normalized(path) == normalized(committed / path.name), (
            f"labs/{lab}/{path.name} differs from what solutions/ generates: run `make labs`"
        )


def test_every_lab_has_a_release() -> None:
    assert LABS_NOW, "no lab in solutions/"
    assert sorted(p.name for p in LABS.iterdir() if p.is_dir()) == LABS_NOW


@pytest.mark.parametrize("lab", LABS_NOW)
def test_solution_scores_full_marks(round_trip: tuple[dict, Path], lab: str) -> None:
    row = round_trip[0][("right", lab)]
    assert float(row["score"]) == float(row["max_score"]) > 0, row


@pytest.mark.parametrize("lab", LABS_NOW)
def test_untouched_release_scores_zero_without_grader_error(
    round_trip: tuple[dict, Path], lab: str
) -> None:
    row = round_trip[0][("untouched", lab)]
    assert row["status"] == "ok", row
    assert float(row["score"]) == 0, row


@pytest.mark.slow
@pytest.mark.parametrize("lab", LABS_NOW)
def test_make_check_and_grading_agree_on_every_cell_of_the_solution(
    round_trip: tuple[dict, Path], lab: str, tmp_path: Path
) -> None:
    """The student's ``make check`` runs each test cell's visible part in the kernel;
    grading runs the whole cell in the judge: on the solution both pass every cell."""
    import subprocess
    import sys

    from autograder.config import ROOT
    from autograder.feedback import is_test_cell
    from tests.labtools import answered

    path = tmp_path / f"{lab}.ipynb"
    nbformat.write(answered(lab), path)
    done = subprocess.run(
        [sys.executable, "-m", "autograder", "check", str(path), "--timeout", "600"],
        capture_output=True, text=True, cwd=ROOT, timeout=1800, check=False,
    )  # fmt: skip
    cells = [line.split()[1] for line in done.stdout.splitlines() if line.startswith("  PASS")]
    failed = [line for line in done.stdout.splitlines() if line.startswith("  FAIL")]
    source = nbformat.read(ROOT / "solutions" / lab / f"{lab}.ipynb", as_version=4)
    tests = [c.metadata.nbgrader["grade_id"] for c in source.cells if is_test_cell(c)]
    assert (done.returncode, failed, cells) == (0, [], tests), done.stdout + done.stderr
    row = round_trip[0][("right", lab)]
    assert float(row["score"]) == float(row["max_score"]), row  # every cell, in the judge
