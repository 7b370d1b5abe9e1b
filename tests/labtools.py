"""Build a lab's fixture submissions from its release and solution, and grade them.

Fixtures are derived from ``labs/`` and ``solutions/`` at test time, so they never go
stale when a lab changes: "right" is the release with every solution cell answered as
in the solution (``autograder.course.answered``, which the book's grading page uses
too), "wrong" replaces some answers, and so on.
"""

from __future__ import annotations

import copy
import csv
import re
import shutil
from pathlib import Path

import nbformat

from autograder.course import (  # noqa: F401 (the tests import them from here too)
    answered,
    grade_id,
    notebook_path,
    solution_answers,
    strip_markers,
)
from autograder.grade import grade_class
from rosbook.runtime.isolation import RUN_MARKER


def replace_in_answer(lab: str, gid: str, old: str, new: str) -> dict[str, str]:
    """A replacement for ``answered``: the solution of ``gid`` with ``old`` -> ``new``."""
    source = strip_markers(solution_answers(lab)[gid])
    assert old in source, f"{old!r} not in the solution of {gid}"
    return {gid: source.replace(old, new)}


def with_cell(notebook: nbformat.NotebookNode, gid: str, source: str) -> nbformat.NotebookNode:
    """A copy of ``notebook`` whose cell ``gid`` (any cell) has ``source``."""
    notebook = copy.deepcopy(notebook)
    for cell in notebook.cells:
        if grade_id(cell) == gid:
            cell.source = source
            return notebook
    raise KeyError(gid)


def submit(
    root: Path, student: str, lab: str, notebook: nbformat.NotebookNode | str | None
) -> None:
    """Place a submission: a notebook, raw text (a broken file), or None (folder, no file)."""
    folder = root / student / lab
    folder.mkdir(parents=True, exist_ok=True)
    if notebook is None:
        return
    path = folder / f"{lab}.ipynb"
    if isinstance(notebook, str):
        path.write_text(notebook)
    else:
        nbformat.write(notebook, path)


def grade(submissions: Path, out: Path, **kwargs: object) -> dict[tuple[str, str], dict[str, str]]:
    """Grade ``submissions``; the grades.csv rows by (student, lab)."""
    grade_class(submissions, out, **kwargs)  # type: ignore[arg-type]
    return grade_rows(out)


def grade_rows(out: Path) -> dict[tuple[str, str], dict[str, str]]:
    """The rows of ``out``'s grades.csv by (student, lab)."""
    with open(out / "grades.csv") as f:
        return {(r["student_id"], r["assignment_id"]): r for r in csv.DictReader(f)}


def with_round_trip(
    graded: tuple[dict, Path],
    round_trip: tuple[dict, Path],
    lab: str,
    students: tuple[str, ...] = ("right",),
) -> tuple[dict, Path]:
    """A lab's class (its rows and out folder) with the rows and feedback pages of
    ``students`` as the run's round trip graded them (the ``round_trip`` fixture: every
    lab's right and untouched submissions, graded once for every test file)."""
    rows, out = graded
    shared_rows, shared_out = round_trip
    for student in students:
        rows[(student, lab)] = shared_rows[(student, lab)]
        page = Path("feedback") / student / lab / f"{lab}.html"
        (out / page).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(shared_out / page, out / page)
    return rows, out


def assert_counted_from_zero(log: str) -> None:
    """``log`` (a lab 1 try-it cell's output) holds the counter publisher's lines,
    ``Publishing: 0``, ``1``, ... in order: at least the first. How many a wall-clock spin
    shows depends on the machine's speed (three on an idle one), never on the code."""
    counts = [int(n) for n in re.findall(r"Publishing: (-?\d+)", log)]
    assert counts and counts == list(range(len(counts))), log


def feedback(out: Path, student: str, lab: str) -> str:
    return (out / "feedback" / student / lab / f"{lab}.html").read_text()


def marked_processes(pid: int) -> list[int]:
    """Live processes started under a ROS domain that the process ``pid`` reserved.

    A job's token is ``<domain>-<pid of the reserving process>-<random>``.
    """
    needle = f"-{pid}-".encode()
    prefix = RUN_MARKER.encode() + b"="
    found = []
    for proc in Path("/proc").glob("[0-9]*"):
        try:
            env = proc.joinpath("environ").read_bytes().split(b"\0")
        except OSError:
            continue
        if any(item.startswith(prefix) and needle in item for item in env):
            found.append(int(proc.name))
    return found
