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
