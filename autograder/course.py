"""nbgrader course directories: generating the student version of a lab."""

from __future__ import annotations

import functools
import shutil
from pathlib import Path

import nbgrader.api
from alembic.script import ScriptDirectory
from nbgrader.apps import NbGraderAPI
from nbgrader.coursedir import CourseDirectory
from nbgrader.dbutil import ALEMBIC_DIR

from autograder.config import LABS, nbgrader_config


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


def generate(course_root: Path, assignment_id: str) -> Path:
    """Run ``generate_assignment`` into ``course_root``; return the released folder.

    Also records the assignment, with its hidden tests, in the course's gradebook.
    """
    course_root.mkdir(parents=True, exist_ok=True)
    result = api(course_root).generate_assignment(assignment_id, force=True, create=True)
    if not result["success"]:
        raise NbgraderError(
            f"generate_assignment {assignment_id} failed:\n{result.get('error') or result['log']}"
        )
    return course_root / "release" / assignment_id


def release_lab(assignment_id: str, work_dir: Path, labs_dir: Path = LABS) -> Path:
    """Regenerate ``labs/<id>/`` from ``solutions/<id>/`` (never edit labs/ by hand)."""
    released = generate(work_dir, assignment_id)
    target = labs_dir / assignment_id
    if target.exists():
        shutil.rmtree(target)
    shutil.copytree(released, target)
    return target
