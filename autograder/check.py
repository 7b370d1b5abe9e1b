"""A student's self-check: run the notebook's visible checks, as grading will.

``make check LAB=lab01_nodes_topics`` runs ``labs/<lab>/<lab>.ipynb`` from top to
bottom in a fresh kernel and its own ROS domain, then says, check by check, what
passes and what does not and why. Hidden checks run only when the lab is graded.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import nbformat
from nbgrader.preprocessors import Execute
from nbgrader.utils import determine_grade

from autograder.config import LABS, nbgrader_config
from autograder.feedback import is_test_cell
from autograder.integrity import grading_code_changes
from autograder.worker import locked_cell_changes
from rosbook.isolation import isolated_environ, kill_marked

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


def run_notebook(path: Path, cell_timeout: int = 30) -> nbformat.NotebookNode:
    """Execute ``path`` in a fresh kernel, in its own ROS domain, next to the notebook."""
    notebook = nbformat.read(path, as_version=4)
    config = nbgrader_config(path.parent, **{"Execute.timeout": cell_timeout})
    import os

    with isolated_environ():
        token = os.environ["ROSBOOK_RUN_TOKEN"]
        try:
            executor = Execute(config=config)
            notebook, _ = executor.preprocess(notebook, {"metadata": {"path": str(path.parent)}})
        finally:
            kill_marked(token)
    return notebook


def error_message(cell: nbformat.NotebookNode) -> str:
    for output in cell.get("outputs", []):
        if output.output_type == "error":
            return f"{output.ename}: {output.evalue}".translate(ANSI_FREE)
        if output.output_type == "stream" and output.name == "stderr":
            text = output.text.strip()[:200]
            return f"wrote to stderr (a graded check fails when it does): {text}"
    return ""


def check(path: Path, cell_timeout: int = 30) -> tuple[list[CheckResult], list[str], list[str]]:
    """Results of the visible checks, the locked cells that differ from the release, and
    the lines that reach into the grading code (``autograder.integrity``)."""
    notebook = run_notebook(path, cell_timeout)
    results = []
    for cell in notebook.cells:
        if is_test_cell(cell):
            points, max_points = determine_grade(cell, None)
            grade_id = cell.metadata.nbgrader["grade_id"]
            results.append(CheckResult(grade_id, points or 0.0, max_points, error_message(cell)))
    release = LABS / path.stem / path.name
    changed, flagged = [], []
    if release.exists():
        released = nbformat.read(release, as_version=4)
        flagged = grading_code_changes(notebook, released)
        if release.resolve() != path.resolve():
            changed = locked_cell_changes(notebook, released)
    return results, changed, flagged


def report(
    path: Path, results: list[CheckResult], changed: list[str], flagged: Sequence[str] = ()
) -> str:
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
    if changed:
        lines.append(
            "  WARNING: these locked cells differ from the released lab and will be "
            "restored before grading: " + ", ".join(changed)
        )
    if flagged:
        lines.append(
            "  WARNING: these lines reach into the grading code; a graded submission "
            "with them is marked 'tampered' for your instructor to review:"
        )
        lines.extend("        " + line for line in flagged)
    return "\n".join(lines)
