"""Deadline-day figures: grading each lab, a class of 60, and resuming a stopped class.

- seconds per submission of each lab: the solution, graded alone;
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
import tempfile
import time
from pathlib import Path

import nbformat

from autograder.config import lab_ids
from autograder.grade import grade_class
from benchmarks import Figure, sized
from tests.labtools import answered, submit

LAB = "lab01_nodes_topics"


def graded_ok(rows: list, expected: int) -> None:
    bad = [r for r in rows if r.status != "ok" or r.score != r.max_score]
    if bad or len(rows) != expected:
        raise RuntimeError(f"benchmark submissions did not all score full marks: {bad}")


def per_lab(work: Path) -> list[Figure]:
    figures = []
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
    return figures


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
