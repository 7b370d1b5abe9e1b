"""A student's self-check: run the notebook's visible checks, as grading will.

``make check LAB=lab01_nodes_topics`` runs ``labs/<lab>/<lab>.ipynb`` from top to
bottom in a fresh kernel and its own ROS domain, then says, check by check, what
passes and what does not and why. Hidden checks run only when the lab is graded.

Every check runs, even after one fails (unlike JupyterLab's "Run All", which stops at
the first error). The report also names what grading will hold against the notebook
beyond the checks: a cell interrupted at the time limit (status ``timeout``), a cell
of the student's that raised, and big outputs (a 3D view) left in the saved file.
The nodes' log lines go to a log file the report names, not into the report.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import nbformat
from nbclient.exceptions import DeadKernelError
from nbgrader.utils import determine_grade

from autograder.config import CELL_TIMEOUT_S, LABS, ROOT, nbgrader_config
from autograder.feedback import cell_name, is_test_cell
from autograder.integrity import grading_code_changes
from autograder.kernels import NOT_RUN, CappedExecute
from autograder.worker import exit_calls, locked_cell_changes, timed_out_cells
from rosbook.runtime.isolation import isolated_environ, kill_marked

ANSI_FREE = str.maketrans("", "", "\x1b")


@dataclass
class CheckResult:
    grade_id: str
    points: float
    max_points: float
    message: str

    @property
    def passed(self) -> bool:
        return self.points >= self.max_points


#: A saved cell output bigger than this is named: a 3D view is about 0.85 MB.
BIG_OUTPUT_BYTES = 200_000

#: Where each lab's node log lines go during ``make check``.
LOG_DIR = ROOT / "_build" / "check"


@dataclass
class SelfCheck:
    """What ``make check`` found: the checks, and what else grading will see."""

    results: list[CheckResult]
    changed: list[str] = field(default_factory=list)  # locked cells that differ
    flagged: list[str] = field(default_factory=list)  # lines reaching into grading code
    timed_out: list[str] = field(default_factory=list)  # cells interrupted at the limit
    not_run: list[str] = field(default_factory=list)  # cells after one the kernel kept
    errors: list[str] = field(default_factory=list)  # student cells that raised
    big_outputs: list[str] = field(default_factory=list)  # saved outputs to clear
    died: list[str] = field(default_factory=list)  # the kernel died: the suspect lines
    cell_timeout: int = 30
    log: Path | None = None

    @property
    def passed(self) -> bool:
        return (
            bool(self.results)
            and all(r.passed for r in self.results)
            and not self.timed_out
            and not self.not_run
        )


@contextmanager
def output_to(log: Path) -> Iterator[None]:
    """Send this process's file descriptors 1 and 2 (and so the kernel's) to ``log``."""
    log.parent.mkdir(parents=True, exist_ok=True)
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    try:
        os.dup2(fd, 1)
        os.dup2(fd, 2)
        yield
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for kept in (fd, *saved):
            os.close(kept)


def run_notebook(path: Path, cell_timeout: int = 30) -> nbformat.NotebookNode:
    """Execute ``path`` in a fresh kernel, in its own ROS domain, next to the notebook."""
    notebook = nbformat.read(path, as_version=4)
    config = nbgrader_config(path.parent, **{"Execute.timeout": cell_timeout})
    with isolated_environ():
        token = os.environ["ROSBOOK_RUN_TOKEN"]
        try:
            executor = CappedExecute(config=config)
            notebook, _ = executor.preprocess(notebook, {"metadata": {"path": str(path.parent)}})
        finally:
            kill_marked(token)
    return notebook


def error_message(cell: nbformat.NotebookNode) -> str:
    for output in cell.get("outputs", []):
        if output.output_type == "error":
            return f"{output.ename}: {output.evalue}".translate(ANSI_FREE).rstrip(": ")
        if output.output_type == "stream" and output.name == "stderr":
            text = output.text.strip()[:200]
            return f"wrote to stderr (a graded check fails when it does): {text}"
    return ""


def student_errors(notebook: nbformat.NotebookNode) -> list[str]:
    """Cells outside the checks that raised, with their error (not the time limit's)."""
    found = []
    for index, cell in enumerate(notebook.cells):
        if cell.cell_type != "code" or is_test_cell(cell):
            continue
        for output in cell.get("outputs", []):
            if output.output_type == "error" and output.ename not in ("CellTimeoutError", NOT_RUN):
                found.append(f"{cell_name(cell, index)}: {error_message(cell)}")
                break
    return found


def big_outputs(notebook: nbformat.NotebookNode, limit: int = BIG_OUTPUT_BYTES) -> list[str]:
    """Cells whose saved outputs are bigger than ``limit`` bytes (a 3D view, a plot)."""
    found = []
    for index, cell in enumerate(notebook.cells):
        size = len(nbformat.writes(nbformat.v4.new_notebook(cells=[cell])))
        if cell.cell_type == "code" and cell.get("outputs") and size > limit:
            found.append(f"{cell_name(cell, index)} ({size / 1e6:.1f} MB)")
    return found


def check(path: Path, cell_timeout: int = CELL_TIMEOUT_S, log: Path | None = None) -> SelfCheck:
    """Run ``path`` as grading will: its visible checks, the cells that timed out or
    raised, the locked cells that differ from the release, the lines that reach into
    the grading code (``autograder.integrity``) and the big outputs saved in it.

    The kernel's output (node log lines) goes to ``log`` (default: the lab's file in
    ``LOG_DIR``)."""
    log = log or LOG_DIR / f"{path.stem}.log"
    saved = nbformat.read(path, as_version=4)
    try:
        with output_to(log):
            notebook = run_notebook(path, cell_timeout)
    except DeadKernelError:
        culprits = exit_calls(saved)
        return SelfCheck([], died=culprits or ["no os._exit, sys.exit or exit() found"], log=log)
    results = []
    for cell in notebook.cells:
        if is_test_cell(cell):
            points, max_points = determine_grade(cell, None)
            grade_id = cell.metadata.nbgrader["grade_id"]
            results.append(CheckResult(grade_id, points or 0.0, max_points, error_message(cell)))
    run = SelfCheck(
        results,
        timed_out=timed_out_cells(notebook),
        not_run=timed_out_cells(notebook, NOT_RUN),
        errors=student_errors(notebook),
        big_outputs=big_outputs(saved),
        cell_timeout=cell_timeout,
        log=log,
    )
    release = LABS / path.stem / path.name
    if release.exists():
        released = nbformat.read(release, as_version=4)
        run.flagged = grading_code_changes(notebook, released)
        if release.resolve() != path.resolve():
            run.changed = locked_cell_changes(notebook, released)
    return run


def report(path: Path, run: SelfCheck) -> str:
    results = run.results
    if run.died:
        return "\n".join(
            [
                f"{path.name}: the Python kernel running it died, so no check could run "
                "after that; grading will say 'error'. A cell must never end the "
                "interpreter (os._exit, sys.exit, exit()). Suspect line(s):",
                *("        " + line for line in run.died),
                f"  (the nodes' log lines: {run.log})",
            ]
        )
    passed = sum(r.passed for r in results)
    lines = [
        f"{path.name}: {passed} of {len(results)} visible checks pass "
        "(hidden checks run when the lab is graded)"
    ]
    for r in results:
        mark = "PASS" if r.passed else "FAIL"
        lines.append(f"  {mark}  {r.grade_id:<28} {r.points:g}/{r.max_points:g}")
        if not r.passed:
            lines.extend("        " + line for line in (r.message or "no output").splitlines())
    if run.timed_out:
        lines.append(
            f"  TIMEOUT  these cells ran longer than {run.cell_timeout} s and were "
            "interrupted; grading will mark the submission 'timeout': "
            + ", ".join(run.timed_out)
            + ". Look for a loop that never ends or a spin without a timeout "
            "(rclpy.spin(node) in a notebook cell)."
        )
    if run.not_run:
        lines.append(
            f"  NOT RUN  a cell was still running {run.cell_timeout} s after it was "
            "interrupted, so these later cells did not run: " + ", ".join(run.not_run)
        )
    if run.errors:
        lines.append("  ERROR  these cells of yours raised (the checks after them may fail too):")
        lines.extend("        " + line for line in run.errors)
    if run.changed:
        lines.append(
            "  WARNING: these locked cells differ from the released lab and will be "
            "restored before grading: " + ", ".join(run.changed)
        )
    if run.flagged:
        lines.append(
            "  WARNING: these lines reach into the grading code; a graded submission "
            "with them is marked 'tampered' for your instructor to review:"
        )
        lines.extend("        " + line for line in run.flagged)
    if run.big_outputs:
        lines.append(
            "  WARNING: big outputs are saved in the notebook (a 3D view is about 1 MB); "
            "clear them before submitting (Edit > Clear Outputs of All Cells, then save): "
            + ", ".join(run.big_outputs)
        )
    if run.log is not None:
        lines.append(f"  (the nodes' log lines: {run.log})")
    return "\n".join(lines)
