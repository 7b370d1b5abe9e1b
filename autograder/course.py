"""nbgrader course directories: generating the student version of a lab; a lab answered
as its solution (what a student who solved it submits)."""

from __future__ import annotations

import functools
import shutil
from pathlib import Path

import nbformat
import nbgrader.api
from alembic.script import ScriptDirectory
from nbgrader.apps import NbGraderAPI
from nbgrader.coursedir import CourseDirectory
from nbgrader.dbutil import ALEMBIC_DIR

from autograder.config import LABS, SOLUTIONS, nbgrader_config


@functools.cache
def alembic_head() -> str:
    """The schema revision nbgrader stamps a new gradebook with, read in this process.

    nbgrader asks the `alembic heads` command for it each time it creates a gradebook:
    a Python start that imports nbgrader again (without the autograder's stand-in for
    rfc3987_syntax), 0.4-5.5 s depending on the machine, for the course template's
    gradebook of every class and once per worker. The answer is fixed for the installed
    nbgrader.
    """
    return ScriptDirectory(ALEMBIC_DIR).get_current_head()


nbgrader.api.get_alembic_version = alembic_head


class NbgraderError(RuntimeError):
    """An nbgrader step failed; the message carries nbgrader's own log."""


def api(course_root: Path, **overrides: object) -> NbGraderAPI:
    config = nbgrader_config(course_root, **overrides)
    return NbGraderAPI(coursedir=CourseDirectory(config=config), config=config)


class UnjudgedLab(ValueError):
    """A lab has test cells the judge cannot decide: it is not released (one line each)."""


def generate(course_root: Path, assignment_id: str, solutions: Path = SOLUTIONS) -> Path:
    """Run ``generate_assignment`` of ``solutions/<assignment_id>`` into ``course_root``;
    return the released folder.

    Also records the assignment, with its hidden tests, in the course's gradebook.
    """
    course_root.mkdir(parents=True, exist_ok=True)
    overrides = {"CourseDirectory.source_directory": str(solutions)}
    result = api(course_root, **overrides).generate_assignment(
        assignment_id, force=True, create=True
    )
    if not result["success"]:
        raise NbgraderError(
            f"generate_assignment {assignment_id} failed:\n{result.get('error') or result['log']}"
        )
    return course_root / "release" / assignment_id


def refuse_unjudged(assignment_id: str, solutions: Path = SOLUTIONS) -> None:
    """Raise ``UnjudgedLab`` naming each test cell of the lab's source notebook that the
    judge has no check for: graded, such a cell would score nothing."""
    from autograder.judge import unjudged_cells

    notebook = nbformat.read(solutions / assignment_id / f"{assignment_id}.ipynb", as_version=4)
    problems = unjudged_cells(assignment_id, notebook)
    if problems:
        raise UnjudgedLab("\n".join(problems))


def release_lab(
    assignment_id: str, work_dir: Path, labs_dir: Path = LABS, solutions: Path = SOLUTIONS
) -> Path:
    """Regenerate ``labs/<id>/`` from ``solutions/<id>/`` (never edit labs/ by hand);
    a lab with a test cell the judge cannot decide is refused (``UnjudgedLab``)."""
    refuse_unjudged(assignment_id, solutions)
    released = generate(work_dir, assignment_id, solutions)
    target = labs_dir / assignment_id
    if target.exists():
        shutil.rmtree(target)
    shutil.copytree(released, target)
    return target


def notebook_path(lab: str, released: bool = True) -> Path:
    """``lab``'s notebook: as released to students, or the instructor's source."""
    return (LABS if released else SOLUTIONS) / lab / f"{lab}.ipynb"


def grade_id(cell: nbformat.NotebookNode) -> str | None:
    """The nbgrader name of ``cell``, if it has one."""
    return cell.get("metadata", {}).get("nbgrader", {}).get("grade_id")


def solution_answers(lab: str) -> dict[str, str]:
    """The instructor's source of every solution cell, by grade_id."""
    solution = nbformat.read(notebook_path(lab, released=False), as_version=4)
    return {
        grade_id(c): c.source
        for c in solution.cells
        if c.get("metadata", {}).get("nbgrader", {}).get("solution")
    }


def strip_markers(source: str) -> str:
    """A solution cell's source without nbgrader's solution markers."""
    lines = source.splitlines()
    return "\n".join(
        ln for ln in lines if ln.strip() not in ("### BEGIN SOLUTION", "### END SOLUTION")
    )


def answered(lab: str, **replacements: str) -> nbformat.NotebookNode:
    """The released notebook as a student who wrote the solution would submit it.

    ``replacements`` give other answers (cell source) for some grade_ids.
    """
    notebook = nbformat.read(notebook_path(lab), as_version=4)
    answers = {k: strip_markers(v) for k, v in solution_answers(lab).items()}
    answers.update(replacements)
    for cell in notebook.cells:
        if grade_id(cell) in answers and cell.metadata.nbgrader.get("solution"):
            cell.source = answers[grade_id(cell)]
    return notebook
