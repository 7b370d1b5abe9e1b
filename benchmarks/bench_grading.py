"""Deadline-day figures: grading each lab, a class of 60, and resuming a stopped class.

- seconds per submission of each lab: the solution, graded alone; lab 9's against lab
  5's (target: at most 2, the navigation runs being lab 5's kind of drive);
- seconds of a student's ``make check`` of each lab's solution (the edit loop), and lab
  1's against its graded submission in the same run (target: at most 1.4; it was 2.8,
  22.8 s against 8.2 s, when ``make check`` ran the sandbox's preflight every time);
- a class of 60 correct lab 1 submissions with ``--workers 2``, end to end (target:
  at most 4 minutes on 2 cores);
- resuming that class when 40 of the 60 are already graded: 20 notebooks are changed
  and the run is resumed, measured against the full run in the same benchmark
  (target: about 20/60 of it, i.e. only the 20 are graded).

Cells get a generous limit (600 s), so that a loaded machine measures time, never a
timeout. ``BENCH_CLASS_SIZE`` shrinks the class (and the resumed part in proportion) for a
quick look; the figures' names say the size measured.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import nbformat

from autograder.config import lab_ids
from autograder.grade import grade_class
from benchmarks import Figure, sized
from tests.labtools import answered, submit

LAB = "lab01_nodes_topics"
#: Lab 9 drives the simulator as lab 5 does: grading one submission of it should take at
#: most twice as long as one of lab 5 (the ratio's figure, when both are measured).
NAVIGATION, DRIVING = "lab09_navigation", "lab05_diff_drive"


def graded_ok(rows: list, expected: int) -> None:
    bad = [r for r in rows if r.status != "ok" or r.score != r.max_score]
    if bad or len(rows) != expected:
        raise RuntimeError(f"benchmark submissions did not all score full marks: {bad}")


def per_lab(work: Path) -> list[Figure]:
    figures = []
    graded: dict[str, float] = {}
    for lab in sized(lab_ids(), [LAB]):
        submissions = work / f"one-{lab}"
        submit(submissions, "student", lab, answered(lab))
        rows = grade_class(
            submissions, work / f"out-{lab}", assignment_id=lab, workers=1, cell_timeout=600
        )
        row = rows[0]
        if row.score != row.max_score:  # the time still counts; say the solution lost points
            print(f"warning: {lab}'s solution scored {row.score:g}/{row.max_score:g}", flush=True)
        figures.append(Figure(f"{lab} seconds per submission", row.seconds, "s"))
        graded[lab] = row.seconds
        checked = self_check_seconds(work / f"check-{lab}", lab)
        figures.append(Figure(f"{lab} make check seconds", checked, "s"))
        if lab == LAB:
            figures.append(
                Figure(
                    f"{lab} make check vs graded (target <= 1.4)", checked / row.seconds, "ratio"
                )
            )
    if NAVIGATION in graded and DRIVING in graded:
        figures.append(
            Figure(
                "lab09 vs lab05 seconds per submission (target <= 2)",
                graded[NAVIGATION] / graded[DRIVING],
                "ratio",
            )
        )
    return figures


def self_check_seconds(folder: Path, lab: str) -> float:
    """Seconds of ``python -m autograder check`` (``make check``) on ``lab``'s solution."""
    folder.mkdir(parents=True)
    path = folder / f"{lab}.ipynb"
    nbformat.write(answered(lab), path)
    start = time.monotonic()
    done = subprocess.run(
        [sys.executable, "-m", "autograder", "check", str(path), "--timeout", "600"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    seconds = time.monotonic() - start
    if done.returncode != 0:  # the time still counts; say what failed
        print(f"warning: make check of {lab}'s solution failed:\n{done.stdout}", flush=True)
    return seconds


def class_run(work: Path, size: int) -> list[Figure]:
    resumed = size // 3
    submissions, out = work / "class", work / "out-class"
    notebook = answered(LAB)
    students = [f"student_{i:03d}" for i in range(size)]
    for student in students:
        submit(submissions, student, LAB, notebook)
    start = time.monotonic()
    graded_ok(grade_class(submissions, out, assignment_id=LAB, workers=2, cell_timeout=600), size)
    full = time.monotonic() - start

    changed = nbformat.from_dict(notebook)
    changed.metadata["resubmitted"] = True  # a new file: graded again on --resume
    for student in students[:resumed]:
        nbformat.write(changed, submissions / student / LAB / f"{LAB}.ipynb")
    start = time.monotonic()
    graded_ok(
        grade_class(submissions, out, assignment_id=LAB, workers=2, cell_timeout=600, resume=True),
        size,
    )
    again = time.monotonic() - start
    done = size - resumed
    return [
        Figure(f"lab01 class of {size}, --workers 2, end to end", full, "s"),
        Figure(f"lab01 resume {size} with {done} graded ({resumed} to grade)", again, "s"),
        Figure(f"lab01 resume vs full class (ideal {resumed}/{size})", again / full, "ratio"),
    ]


def run() -> list[Figure]:
    size = int(os.environ.get("BENCH_CLASS_SIZE", sized("60", "3")))
    with tempfile.TemporaryDirectory(prefix="bench-grading-") as tmp:
        work = Path(tmp)
        return per_lab(work) + class_run(work, size)
