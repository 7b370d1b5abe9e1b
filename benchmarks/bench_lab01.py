"""Lab 1 grading speed: per submission, and against plain sequential nbgrader.

Twenty correct submissions are graded twice in the same run: by ``python -m autograder
grade --workers 2`` (isolated, parallel, with feedback) and by one plain ``nbgrader
autograde`` of all twenty (sequential, no feedback). Target: ratio at most 0.6.
"""

from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from autograder.config import PACKAGE_DIR, SOLUTIONS
from autograder.grade import grade_class
from benchmarks import Figure
from rosbook.isolation import run_isolated
from tests.labtools import answered, submit

LAB = "lab01_nodes_topics"
STUDENTS = [f"student_{i:02d}" for i in range(20)]


def plain_nbgrader_seconds(submissions: Path, work: Path) -> float:
    """Sequential ``nbgrader autograde`` of every student, in one isolated domain."""
    course = work / "course"
    shutil.copytree(SOLUTIONS / LAB, course / "solutions" / LAB)
    shutil.copytree(submissions, course / "submitted")
    shutil.copy(PACKAGE_DIR / "nbgrader_config.py", course)  # read from the working folder
    nbgrader = [sys.executable, "-m", "nbgrader"]
    common = ["--log-level=ERROR"]
    subprocess.run(
        [*nbgrader, "generate_assignment", LAB, "--force", *common], check=True, cwd=course
    )
    start = time.monotonic()
    code = run_isolated([*nbgrader, "autograde", LAB, "--create", "--force", *common], cwd=course)
    elapsed = time.monotonic() - start
    if code != 0:
        raise RuntimeError(f"nbgrader autograde failed with exit code {code}")
    return elapsed


def run() -> list[Figure]:
    with tempfile.TemporaryDirectory(prefix="bench-lab01-") as tmp:
        work = Path(tmp)
        submissions = work / "submissions"
        notebook = answered(LAB)
        for student in STUDENTS:
            submit(submissions, student, LAB, notebook)
        start = time.monotonic()
        rows = grade_class(submissions, work / "out", assignment_id=LAB, workers=2)
        ours = time.monotonic() - start
        bad = [r for r in rows if r.status != "ok" or r.score != r.max_score]
        if bad:
            raise RuntimeError(f"benchmark submissions did not all score full marks: {bad}")
        baseline = plain_nbgrader_seconds(submissions, work)
    return [
        Figure("lab01 seconds per submission", statistics.median(r.seconds for r in rows), "s"),
        Figure("lab01 grading 20 submissions, --workers 2", ours, "s"),
        Figure("lab01 sequential nbgrader autograde of 20", baseline, "s"),
        Figure("lab01 grading vs sequential nbgrader", ours / baseline, "ratio"),
    ]
