"""The grader's side of the judge: ask for verdicts while nbgrader runs, score with them.

``JudgedExecute`` is nbgrader's ``Execute`` preprocessor that, just before each test
cell runs in the student's kernel, asks the judge process (``autograder.judge``) for
its verdict on that cell, with the kernel in the state the student's cells left it.
The kernel gets the cell without its hidden tests: their source never enters it. A
test cell the judge has no check for scores nothing (never its run in the kernel).
The cell then runs in the kernel deferred (``rosbook.labs.deferral``; unless the feedback
keeps figures its checks show, ``shows_figures``, and the judge did not show them of its
own runs): its checks raise ``CheckDeferred`` at once instead of running a second time,
and the cell's output shows the judge's figures and verdict instead. Honest code cannot
pass a deferred cell in the kernel, so a pass there is a forged one. The verdicts stay in
the grading worker, outside the kernel; ``apply_verdicts`` then makes them the cells'
scores in the gradebook (as nbgrader's manual score, so feedback and totals show them)
and names the cells whose output claimed a pass the judge did not give.
"""

from __future__ import annotations

import copy
import json
import re
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import nbformat
from nbformat import NotebookNode
from nbformat.v4 import new_output
from nbgrader.api import Gradebook
from nbgrader.preprocessors import ClearHiddenTests, Execute

from autograder import sandbox
from autograder.feedback import is_test_cell
from autograder.judge import (
    VERDICT_GUARD_S,
    Verdict,
    calls_checks,
    setup_cells,
)
from autograder.kernels import CappedExecute, not_run_output


def verdict_guard(cell_timeout: float | None) -> float:
    """How long the grader waits for the judge's verdict on one cell: never less than
    the cell's limit, which each of the cell's own waits may take (``Judgement.guard``),
    so a limit raised for a slow machine raises this one too."""
    return max(VERDICT_GUARD_S, cell_timeout or 0.0)


#: Run silently in the kernel just before a judged test cell: its checks are deferred.
DEFER_CELL = "__import__('rosbook.labs.deferral', fromlist=['_']).defer_this_cell()"


@dataclass
class Judging:
    """One submission's judge process and the verdicts it gave."""

    assignment_id: str
    verdicts: dict[str, Verdict] = field(default_factory=dict)
    process: subprocess.Popen[str] | None = None
    #: Test cells whose run in the kernel calls the lab's checks (deferred there): only
    #: such a cell's pass in the kernel is a forged one.
    deferring: set[str] = field(default_factory=set)
    #: Test cells whose run in the kernel ended without an error (a pass, there).
    kernel_passed: set[str] = field(default_factory=set)
    #: The test cells met so far (the judge decides each).
    cells: set[str] = field(default_factory=set)

    def start(self) -> None:
        """Start this submission's judge unless it runs: its interpreter, rclpy and ROS
        start while the kernel starts and the student's cells run, not at the first
        judged cell. It is this submission's own and ends with it."""
        if self.process is not None and self.process.poll() is None:
            return
        argv = [sys.executable, "-I", "-m", "autograder.judge", self.assignment_id]
        network = sandbox.current_network()  # the kernel's: the judge joins it
        self.process = subprocess.Popen(
            network.join_argv(argv) if network is not None else argv,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            cwd=Path(__file__).resolve().parent.parent,
            start_new_session=True,
        )

    def verdict(
        self,
        grade_id: str,
        connection_file: str,
        folder: str,
        sandbox_pid: int | None = None,
        cell_timeout: float | None = None,
        source: str = "",
        setup: list[str] | None = None,
    ) -> Verdict:
        """The judge's verdict on test cell ``grade_id`` (``source``: the instructor's,
        hidden tests and all; ``setup``: the notebook's setup cells)."""
        self.start()  # again if it died on an earlier check
        assert self.process is not None
        assert self.process.stdin is not None and self.process.stdout is not None
        request = {
            "assignment": self.assignment_id,
            "check": grade_id,
            "connection_file": connection_file,
            "folder": folder,
            "sandbox_pid": sandbox_pid,
            "cell_timeout": cell_timeout,
            "source": source,
            "setup": setup or [],
        }
        try:
            self.process.stdin.write(json.dumps(request) + "\n")
            self.process.stdin.flush()
            line = _read_line(self.process, verdict_guard(cell_timeout))
        except OSError:
            line = ""
        if line is None:
            self.stop()
            return Verdict(grade_id, False, "timeout: the judge gave no verdict", timeout=True)
        if not line:
            self.stop()
            return Verdict(grade_id, False, "the judge process died on this check", broken=True)
        return Verdict(**json.loads(line))

    def stop(self) -> None:
        if self.process is not None:
            if self.process.stdin is not None:
                self.process.stdin.close()
            try:
                self.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
            self.process = None


def _read_line(process: subprocess.Popen[str], timeout: float) -> str | None:
    """One line from the judge; "" when it died, None after ``timeout`` seconds."""
    import select

    assert process.stdout is not None
    ready, _, _ = select.select([process.stdout], [], [], timeout)
    return process.stdout.readline() if ready else None


_current: Judging | None = None


@contextmanager
def judging(assignment_id: str) -> Iterator[Judging]:
    """Judge the test cells of ``assignment_id`` for the nbgrader run inside this block."""
    global _current
    _current = Judging(assignment_id)
    try:
        _current.start()
        yield _current
    finally:
        _current.stop()
        _current = None


class JudgedExecute(CappedExecute):  # type: ignore[misc]
    """nbgrader's Execute (output capped, as for every kernel), with the judge's verdict
    taken before each test cell: the judge runs the instructor's cell (hidden tests and
    all), the kernel gets it without its hidden tests (``sent_to_kernel``), and its run
    in the kernel never scores."""

    def preprocess_cell(
        self, cell: NotebookNode, resources: dict[str, Any], index: int
    ) -> tuple[NotebookNode, dict[str, Any]]:
        if _current is None or not is_test_cell(cell):
            return super().preprocess_cell(cell, resources, index)  # type: ignore[no-any-return]
        grade_id = cell.get("metadata", {}).get("nbgrader", {}).get("grade_id")
        sent = sent_to_kernel(cell)
        busy = self.busy_with is not None
        _current.cells.add(grade_id)
        if calls_checks(sent.source, setup_cells(self.nb)):
            _current.deferring.add(grade_id)
        if self.busy_with is not None:  # the judge would wait on the kernel for nothing
            verdict = Verdict(
                grade_id,
                False,
                f"timeout: {not_run_output(self.busy_with, self.timeout).evalue}",
                timeout=True,
            )
        else:
            self.make_room(resources, index)  # the judge runs programs in the sandbox
            # A sandbox's folder is seen through /proc/<pid>/root: never resolved (that
            # link would lead to the host's own root).
            folder = getattr(self.km, "sandbox_folder", None) or str(
                Path(resources.get("metadata", {}).get("path", ".")).resolve()
            )
            verdict = _current.verdict(
                grade_id,
                self.km.connection_file,
                folder,
                getattr(self.km, "sandbox_pid", None),
                self.timeout,
                cell.source,
                setup_cells(self.nb),
            )
        _current.verdicts[grade_id] = verdict
        shown = [nbformat.from_dict(output) for output in verdict.outputs]
        # a check that timed out in the judge would only time out again in the kernel
        if (
            self.busy_with is None
            and sent.source.strip()
            and (shown or verdict.timeout or not shows_figures(sent.source))
        ):
            defer_next_cell(self.kc)
        sent, resources = super().preprocess_cell(sent, resources, index)
        ran = sent.get("outputs", [])
        if sent.source.strip() and not any(o.get("output_type") == "error" for o in ran):
            _current.kernel_passed.add(grade_id)
        if busy:  # not run, in the kernel nor in the judge
            outputs = list(ran)
        elif any(map(is_deferral, ran)):
            outputs = []
            for output in ran:
                outputs += [*shown, verdict_output(verdict)] if is_deferral(output) else [output]
        else:  # its run in the kernel (a hint) or none, then the verdict that scores
            outputs = [*ran, *shown, verdict_output(verdict)]
        cell.outputs, cell.execution_count = outputs, sent.get("execution_count")
        # nbclient put the copy it ran in the notebook: the graded notebook keeps the
        # instructor's cell (hidden tests and all) for nbgrader and the gradebook
        self.nb.cells[index] = cell
        return cell, resources


def sent_to_kernel(cell: NotebookNode) -> NotebookNode:
    """A copy of test cell ``cell`` as the student's kernel gets it: its hidden tests
    removed as nbgrader removes them from the release (``ClearHiddenTests``), so no
    hidden test's source reaches the kernel (its history, its hooks, its outputs).
    A cell whose hidden region is malformed is not sent at all (empty source)."""
    sent = copy.deepcopy(cell)
    try:
        ClearHiddenTests(enforce_metadata=False).preprocess_cell(sent, {}, 0)
    except RuntimeError:  # a hidden region without its end: nothing of it goes out
        sent.source = ""
    return sent


def shows_figures(source: str) -> bool:
    """Whether a test cell shows figures made by its checks (``checks.show_path(...)``,
    the labs' ``show_*``): the feedback keeps them, so unless the judge showed them
    itself (the runs it judged, ``Verdict.outputs``) it runs in the kernel as written."""
    return re.search(r"\.show_\w+\(", source) is not None


def defer_next_cell(client: Any) -> None:
    """Have the kernel of ``client`` defer the checks of the next cell it runs. Sent
    ahead of that cell (a kernel runs requests in order), silently: its reply and
    output are not the cell's, so nbclient skips them."""
    client.execute(DEFER_CELL, silent=True, store_history=False, stop_on_error=False)


def is_deferral(output: NotebookNode) -> bool:
    """Whether ``output`` is a deferred check's error (``rosbook.labs.deferral``)."""
    return output.get("output_type") == "error" and output.get("ename") == "CheckDeferred"


def verdict_output(verdict: Verdict) -> NotebookNode:
    """The judge's verdict as the cell's output: a pass, or its error and message."""
    if verdict.passed:
        text = "passed: the grader checked this cell on your code, outside your notebook\n"
        return new_output("stream", name="stdout", text=text)
    ename = "GraderError" if verdict.broken else "CheckFailed"
    return new_output(
        "error",
        ename=ename,
        evalue=verdict.message,
        traceback=[f"{ename}: {verdict.message}"],
    )


def judged_preprocessors() -> list[type]:
    """nbgrader's autograde preprocessors with ``Execute`` replaced by ``JudgedExecute``."""
    from nbgrader.converters import Autograde

    default = Autograde.class_traits()["autograde_preprocessors"].default()
    return [JudgedExecute if p in (Execute, CappedExecute) else p for p in default]


@dataclass
class Judged:
    """What the verdicts changed: cells whose output claimed a pass the judge did not
    give, cells the judge timed out on or could not judge, and the judge's messages."""

    claimed: list[str] = field(default_factory=list)
    timed_out: list[str] = field(default_factory=list)
    broken: list[str] = field(default_factory=list)
    messages: dict[str, str] = field(default_factory=dict)


def apply_verdicts(
    gradebook: Path, assignment_id: str, student_id: str, notebook: str, run: Judging
) -> Judged:
    """Make the judge's verdicts the scores of the test cells; a test cell with no
    verdict (never reached, judge failed, no check in the judge) scores nothing: its run
    in the student's kernel never scores."""
    judged = Judged()
    with Gradebook(f"sqlite:///{gradebook}") as gb:
        sub = gb.find_submission_notebook(notebook, assignment_id, student_id)
        for grade in sub.grades:
            if grade.name not in run.verdicts and grade.name not in run.cells:
                if grade.auto_score is None:  # not a test cell: graded by hand
                    continue
            verdict = run.verdicts.get(grade.name)
            passed = verdict is not None and verdict.passed
            grade.manual_score = grade.max_score if passed else 0.0
            if verdict is not None and verdict.timeout:
                judged.timed_out.append(grade.name)
            elif verdict is None or verdict.broken:
                judged.broken.append(grade.name)
            elif not passed and grade.name in run.deferring & run.kernel_passed:
                judged.claimed.append(grade.name)
            if not passed:
                judged.messages[grade.name] = (
                    verdict.message if verdict else "the judge gave no verdict on this cell"
                )
        gb.db.commit()
    return judged
