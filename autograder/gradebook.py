"""The course's nbgrader gradebook: OUT is an nbgrader course folder.

``OUT/gradebook.db`` holds every graded submission's per-cell scores and comments,
``OUT/autograded/<student>/<lab>/<lab>.ipynb`` the notebooks as graded, and
``OUT/feedback/<student>/<lab>/<lab>.html`` the feedback (nbgrader's own layout), so
nbgrader's tools work from OUT: ``nbgrader formgrader`` for review and manual scores,
``nbgrader export`` for the LMS, ``nbgrader generate_feedback`` after a manual change.

A regrade updates the autograder's scores and leaves a score set by hand in place, as
nbgrader's own ``autograde`` does (the cell is then flagged for review again).
"""

from __future__ import annotations

import json
import shutil
import warnings
from dataclasses import dataclass
from pathlib import Path

from nbgrader.api import Gradebook, MissingEntry
from sqlalchemy.exc import SAWarning

from autograder.config import PACKAGE_DIR, SOLUTIONS
from autograder.course import generate
from autograder.results import write_atomic


@dataclass
class CellGrade:
    notebook: str
    name: str  # the cell's grade_id
    auto_score: float | None


@dataclass
class CellComment:
    notebook: str
    name: str
    auto_comment: str | None


def course_config() -> str:
    """``OUT/nbgrader_config.py``: the course's configuration, rooted at OUT."""
    return (
        '"""nbgrader configuration of this grading folder (written by python -m autograder)."""\n'
        f"load_subconfig({str(PACKAGE_DIR / 'nbgrader_config.py')!r})  # noqa: F821\n"
        "c = get_config()  # noqa: F821\n"
        f"c.CourseDirectory.source_directory = {str(SOLUTIONS)!r}\n"
        'c.CourseDirectory.release_directory = "release"\n'
    )


def db_url(out: Path) -> str:
    return f"sqlite:///{out / 'gradebook.db'}"


def read_scratch(scratch: Path, assignment_id: str, student_id: str) -> tuple[list, list]:
    """The per-cell grades and comments a worker's scratch gradebook holds."""
    grades: list[CellGrade] = []
    comments: list[CellComment] = []
    with Gradebook(db_url(scratch)) as gb:
        for nb in gb.find_submission(assignment_id, student_id).notebooks:
            grades += [CellGrade(nb.name, g.name, g.auto_score) for g in nb.grades]
            comments += [CellComment(nb.name, c.name, c.auto_comment) for c in nb.comments]
    return grades, comments


def record(
    out: Path,
    assignment_id: str,
    student_id: str,
    status: str,
    grades: list[CellGrade] | None,
    comments: list[CellComment],
) -> None:
    """Put one graded submission in the course gradebook.

    A ``missing`` notebook has no submission. ``grades`` None means nbgrader produced no
    scores (a notebook that could not be graded): zero in every cell, flagged for review.
    """
    with Gradebook(db_url(out)) as gb, warnings.catch_warnings():
        # nbgrader's add_submission trips SQLAlchemy's autoflush warnings (harmless)
        warnings.simplefilter("ignore", SAWarning)
        gb.update_or_create_student(student_id)
        if status == "missing":
            try:
                gb.remove_submission(assignment_id, student_id)
            except MissingEntry:
                pass
            return
        submission = gb.update_or_create_submission(assignment_id, student_id)
        if grades is None:
            for nb in submission.notebooks:
                for grade in nb.grades:
                    grade.auto_score = 0
                    grade.needs_manual_grade = True
        else:
            for g in grades:
                grade = gb.find_grade(g.name, g.notebook, assignment_id, student_id)
                grade.auto_score = g.auto_score
                grade.needs_manual_grade = grade.manual_score is not None or g.auto_score is None
        for c in comments:
            comment = gb.find_comment(c.name, c.notebook, assignment_id, student_id)
            comment.auto_comment = c.auto_comment
        gb.db.commit()


def add_assignment(out: Path, template: Path, assignment_id: str, digest: str) -> None:
    """Make OUT an nbgrader course holding ``assignment_id`` as generated in ``template``.

    A new gradebook is the template's (creating one costs nbgrader seconds of schema
    migrations); an existing one gets the lab generated again only when its source
    changed (``digest``), which keeps every submission and manual score in it.
    """
    write_atomic(out / "nbgrader_config.py", course_config())
    labs_file = out / "labs.json"
    labs = json.loads(labs_file.read_text()) if labs_file.exists() else {}
    if not (out / "gradebook.db").exists():
        shutil.copy(template / "gradebook.db", out / "gradebook.db")
    elif labs.get(assignment_id) != digest:
        generate(out, assignment_id)
    labs[assignment_id] = digest
    write_atomic(labs_file, json.dumps(labs, indent=1))
