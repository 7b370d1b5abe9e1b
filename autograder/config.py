"""Paths of the project and the nbgrader configuration every command shares."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from traitlets.config import Config
from traitlets.config.loader import PyFileConfigLoader

PACKAGE_DIR = Path(__file__).resolve().parent
ROOT = PACKAGE_DIR.parent
SOLUTIONS = ROOT / "solutions"
LABS = ROOT / "labs"
#: Seconds one cell may run before it is interrupted (a hang guard: a try-it cell that
#: builds a package with colcon needs a generous one on a busy machine).
CELL_TIMEOUT_S = 60

# nbgrader runs `alembic` (its database migrations) as a command (`nbgrader db upgrade`,
# and a new gradebook's revision where autograder.course does not answer it): the venv's
# bin folder must be on PATH even when the venv's python was started by its full path.
_BIN = str(Path(sys.executable).parent)
if _BIN not in os.environ.get("PATH", "").split(os.pathsep):
    os.environ["PATH"] = _BIN + os.pathsep + os.environ.get("PATH", "")


def nbgrader_config(course_root: Path, **overrides: object) -> Config:
    """The course's nbgrader config, rooted at ``course_root``.

    ``overrides`` are dotted names, e.g. ``{"Execute.timeout": 5}``.
    """
    config = PyFileConfigLoader("nbgrader_config.py", path=str(PACKAGE_DIR)).load_config()
    config.CourseDirectory.root = str(course_root)
    config.CourseDirectory.source_directory = str(SOLUTIONS)
    config.CourseDirectory.release_directory = "release"
    config.CourseDirectory.db_url = f"sqlite:///{course_root / 'gradebook.db'}"
    for dotted, value in overrides.items():
        section, name = dotted.rsplit(".", 1)
        setattr(config[section], name, value)
    return config


def lab_ids(solutions: Path = SOLUTIONS) -> list[str]:
    """Every lab in ``solutions`` (default: ``solutions/``), in order."""
    return sorted(p.name for p in solutions.iterdir() if (p / f"{p.name}.ipynb").exists())
