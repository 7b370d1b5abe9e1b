"""Grade submissions, one at a time, each in its own scratch course and ROS domain.

``grade`` starts one worker process per parallel slot (``python -m autograder.worker
RESULT_FD``) and sends it jobs, one JSON line each, on its standard input; the worker
answers each with a JSON line on ``RESULT_FD``. A job carries its environment (its own
ROS domain), which the notebook's kernel inherits. The parent enforces the wall-clock
limit: a worker that overruns is killed with everything it started, and replaced.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import sys
import time
import traceback
import warnings
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import nbformat
from nbgrader.api import Gradebook, MissingEntry
from nbgrader.utils import compute_checksum
from sqlalchemy.exc import SAWarning

from autograder import kernels, sandbox
from autograder.course import api
from autograder.feedback import GRADER_ERROR, accessible, add_notice, cell_name, is_test_cell
from autograder.integrity import grading_code_changes
from autograder.verdicts import Judged, apply_verdicts, judged_preprocessors, judging


@dataclass
class Job:
    template: str  # course root holding gradebook.db and release/<assignment>/
    assignment_id: str
    student_id: str
    submission_dir: str  # the student's <assignment> folder
    notebook: str  # file name of the notebook
    scratch: str  # this submission's own course root
    feedback: str  # where its feedback HTML goes
    cell_timeout: int
    env: dict[str, str] = field(default_factory=dict)  # the kernel's ROS isolation
    next_env: dict[str, str] = field(default_factory=dict)  # the next job's, if known
    log: str = ""  # where this job's output goes


@dataclass
class Result:
    score: float
    max_score: float
    status: str
    message: str = ""


def locked_cell_changes(
    submitted: nbformat.NotebookNode, released: nbformat.NotebookNode
) -> list[str]:
    """grade_ids of locked cells (tests, set-up, instructions) the student changed or removed."""
    by_id = {}
    for cell in submitted.cells:
        grade_id = cell.get("metadata", {}).get("nbgrader", {}).get("grade_id")
        if grade_id:
            by_id[grade_id] = cell
    changed = []
    for cell in released.cells:
        meta = cell.get("metadata", {}).get("nbgrader", {})
        if not meta.get("locked") or meta.get("solution"):
            continue
        theirs = by_id.get(meta["grade_id"])
        if theirs is None or compute_checksum(theirs) != compute_checksum(cell):
            changed.append(meta["grade_id"])
    return changed


def timed_out_cells(notebook: nbformat.NotebookNode, ename: str = "CellTimeoutError") -> list[str]:
    """Cells nbgrader interrupted because they ran past the per-cell limit (with
    ``ename=kernels.NOT_RUN``: the cells not run after one kept the kernel busy)."""
    return [
        cell_name(cell, index)
        for index, cell in enumerate(notebook.cells)
        if any(
            output.get("output_type") == "error" and output.get("ename") == ename
            for output in cell.get("outputs", [])
        )
    ]


def exit_calls(notebook: nbformat.NotebookNode) -> list[str]:
    """Student cells that may kill the kernel (os._exit, sys.exit, exit, quit)."""
    suspects = ("os._exit(", "sys.exit(", "exit(", "quit(", "os.kill(")
    found = []
    for index, cell in enumerate(notebook.cells):
        if cell.cell_type == "code" and not is_test_cell(cell):
            source = "".join(cell.source)
            for line in source.splitlines():
                code = line.split("#", 1)[0]
                if any(s in code for s in suspects) and "rclpy" not in code:
                    meta = cell.get("metadata", {}).get("nbgrader", {})
                    found.append(f"{meta.get('grade_id') or f'cell {index + 1}'}: {line.strip()}")
    return found


#: A submitted notebook larger than this is refused (the lab's own is ~50 KB).
MAX_NOTEBOOK_BYTES = 20 << 20


def refusal(folder: Path, notebook: str) -> str | None:
    """Why a submission is not graded at all (a link, a huge file), or None.

    A link is never followed: to /etc/passwd it would show the grader's file in the
    feedback, to another student's notebook it would earn their marks.
    """
    student = folder.parent
    for path in (student, folder, folder / notebook):
        if path.is_symlink():
            return (
                f"{path.relative_to(student.parent)} is a symbolic link, not a file you "
                "wrote; links are never followed. Submit the notebook itself."
            )
    size = (folder / notebook).stat().st_size
    if size > MAX_NOTEBOOK_BYTES:
        return (
            f"{notebook} is {size / 2**20:.0f} MB, more than the {MAX_NOTEBOOK_BYTES >> 20} MB "
            "a submission may be; clear its outputs (Kernel > Restart and Clear Outputs) "
            "and save it again."
        )
    return None


def deduplicate_grade_ids(notebook: nbformat.NotebookNode) -> list[str]:
    """Keep nbgrader's metadata on the first cell of each grade_id only.

    JupyterLab's copy and paste keeps a cell's metadata, so honest work can hold two
    cells with one grade_id, which nbgrader refuses (the whole notebook scores 0).
    Every copy still runs, in order, as a plain cell (a class defined again in it is
    the one the checks see). Returns the grade_ids copied.
    """
    seen, copied = set(), []
    for cell in notebook.cells:
        gid = cell.get("metadata", {}).get("nbgrader", {}).get("grade_id")
        if gid is None:
            continue
        if gid in seen:
            del cell.metadata["nbgrader"]
            copied.append(gid)
        seen.add(gid)
    return copied


#: What nbgrader's log holds when the kernel never ran a cell: its sandbox or its start
#: failed (jupyter_client's words, ``sandbox.SandboxUnavailable``, bwrap's own).
NOT_STARTED = ("Kernel died before replying to kernel_info", "SandboxUnavailable", "bwrap: ")


def grader_failure(log: str) -> str | None:
    """The line of nbgrader's ``log`` saying the kernel never started (the grader's
    failure, never the student's); None when it started."""
    lines = [line.strip() for line in log.splitlines()]
    return next((line for line in reversed(lines) for mark in NOT_STARTED if mark in line), None)


def grade(job: Job) -> Result:
    scratch = Path(job.scratch)
    template = Path(job.template)
    refused = refusal(Path(job.submission_dir), job.notebook)
    if refused:
        return Result(0, 0, "error", refused)
    submitted_dir = scratch / "submitted" / job.student_id / job.assignment_id
    shutil.copytree(job.submission_dir, submitted_dir, symlinks=True)
    shutil.copy(template / "gradebook.db", scratch / "gradebook.db")
    notebook_path = submitted_dir / job.notebook
    submitted = nbformat.read(notebook_path, as_version=4)
    if deduplicate_grade_ids(submitted):
        nbformat.write(submitted, notebook_path)

    released = nbformat.read(template / "release" / job.assignment_id / job.notebook, as_version=4)
    tampered = locked_cell_changes(submitted, released)
    meddling = grading_code_changes(submitted, released)

    grader = api(
        scratch,
        **{
            "Execute.timeout": job.cell_timeout,
            "Autograde.autograde_preprocessors": judged_preprocessors(),
        },
    )
    started = time.monotonic()
    kernels.REAPED.clear()
    # The kernel's only network (that of the kernel started for this job at the end of
    # the last one, if any: kernels.adopt_spare); the judge joins it (verdicts.Judging).
    network = kernels.adopt_spare(job.env) or sandbox.Network()
    kernels.expect_next(job.next_env)
    try:
        with network, sandbox.using(network), judging(job.assignment_id) as run:
            with warnings.catch_warnings():  # as in gradebook.record: nbgrader's harmless
                warnings.simplefilter("ignore", SAWarning)  # autoflush warnings, not in logs
                outcome = grader.autograde(
                    job.assignment_id, job.student_id, force=True, create=True
                )
    finally:
        kernels.drop_adopted()
        kernels.expect_next(None)
    print(f"[grader] autograde took {time.monotonic() - started:.2f} s", flush=True)
    if not outcome["success"]:
        log = outcome.get("log", "") + outcome.get("error", "")
        failure = grader_failure(log)
        if failure:  # the sandbox's own words (bwrap's) are in the kernel's log: this job's
            said = Path(job.log).read_text(errors="replace") if job.log else ""
            cause = grader_failure(said) if failure != grader_failure(said) else None
            said = f"{failure} ({cause})" if cause else failure
            return Result(0, 0, GRADER_ERROR, f"The grader failed before any cell ran: {said}")
        if "DeadKernelError" in log or "Kernel died" in log or "kernel died" in log:
            culprits = exit_calls(submitted)
            where = f" Suspect line(s): {'; '.join(culprits)}." if culprits else ""
            return Result(
                0,
                0,
                "error",
                "The Python kernel running your notebook died, so "
                "no check could run after that. A cell must never end the "
                f"interpreter (os._exit, sys.exit, exit()).{where}",
            )
        tail = "\n".join(log.strip().splitlines()[-12:])
        return Result(0, 0, "error", f"nbgrader could not grade this notebook:\n{tail}")

    gradebook = scratch / "gradebook.db"
    try:
        judged = apply_verdicts(
            gradebook, job.assignment_id, job.student_id, Path(job.notebook).stem, run
        )
    except MissingEntry:
        return Result(0, 0, "error", "nbgrader recorded no grades for this notebook")
    with Gradebook(f"sqlite:///{gradebook}") as gb:
        sub = gb.find_submission_notebook(
            Path(job.notebook).stem, job.assignment_id, job.student_id
        )
        score, max_score = float(sub.score), float(sub.max_score)

    autograded = nbformat.read(
        scratch / "autograded" / job.student_id / job.assignment_id / job.notebook, as_version=4
    )
    # A judged test cell's run in the kernel is only a hint for the student: when it is
    # slow, the judge's verdict still stands, and the machine's speed decides nothing.
    slow = [c for c in timed_out_cells(autograded) if c not in run.cells]
    not_run = [c for c in timed_out_cells(autograded, kernels.NOT_RUN) if c not in run.cells]

    started = time.monotonic()
    feedback = grader.generate_feedback(job.assignment_id, job.student_id, force=True)
    print(f"[grader] feedback took {time.monotonic() - started:.2f} s", flush=True)
    page = (
        scratch
        / "feedback"
        / job.student_id
        / job.assignment_id
        / (Path(job.notebook).stem + ".html")
    )
    if not feedback["success"] or not page.exists():
        tail = "\n".join((feedback.get("log", "") + feedback.get("error", "")).splitlines()[-8:])
        return Result(score, max_score, "error", f"feedback could not be generated:\n{tail}")

    if tampered:
        status = "tampered"
        message = (
            "Locked cells were changed or removed: " + ", ".join(tampered) + ". They were "
            "restored from the original and your work was graded with the original checks; "
            "your instructor sees this submission marked 'tampered'."
        )
        add_notice(page, "Locked cells changed", message, status)
    else:
        status, message = timeout_status(page, slow, judged, job.cell_timeout, not_run)
    status, message = judged_status(page, judged, status, message)
    if meddling:  # tampering too, though no locked cell changed: for a person to judge
        status = "tampered"
        said = (
            "Your cells reach into the code that grades them: "
            + "; ".join(meddling)
            + ". The score is what the checks gave; your instructor sees this submission "
            "marked 'tampered' and will review it."
        )
        message = f"{message} {said}".strip()
        add_notice(page, "Grading code changed", said, status)
    if kernels.REAPED:
        said = (
            "Your notebook kept its sandbox at the limit of "
            f"{sandbox.Limits.processes} processes and threads (programs started and "
            f"never ended), leaving the kernel no room: the grader ended "
            f"{sum(kernels.REAPED)} of them so that the other cells could run."
        )
        add_notice(page, "Processes ended", said, "error")
        message = f"{message} {said}".strip()
    destination = Path(job.feedback)
    destination.parent.mkdir(parents=True, exist_ok=True)
    destination.write_text(accessible(page.read_text(encoding="utf-8")), encoding="utf-8")
    return Result(score, max_score, status, message)


def timeout_status(
    page: Path,
    slow: list[str],
    judged: Judged,
    cell_timeout: int,
    not_run: Sequence[str] = (),
) -> tuple[str, str]:
    """'timeout' and what ran out of time, or 'ok': cells the kernel interrupted at the
    cell limit (and those not run because one kept the kernel busy), and cells whose
    check by the judge hit its guard (with what the judge waited for), each said as
    what it is."""
    said = []
    if slow or not_run:
        text = (
            f"These cells ran longer than {cell_timeout} s and were interrupted: "
            + ", ".join(slow)
            + ". Look for a loop that never ends or a spin without a timeout."
            if slow
            else ""
        )
        if not_run:
            text += (
                f" A cell was still running {cell_timeout} s after it was interrupted, so "
                "these later cells did not run: " + ", ".join(not_run) + "."
            )
        said.append(text.strip())
        add_notice(page, "Cells interrupted", said[-1], "timeout")
    if judged.timed_out:
        said.append(
            "The grader's own check of these cells ran out of time before it could decide, "
            "so they score nothing until your instructor regrades: "
            + "; ".join(f"{gid} ({judged.messages[gid]})" for gid in judged.timed_out)
            + ". A timeout is not a verdict that your code is wrong: look for a callback "
            "that blocks or a node that stops answering; your instructor sees this "
            "submission marked 'timeout'."
        )
        add_notice(page, "Checks that ran out of time", said[-1], "timeout")
    return ("timeout", " ".join(said)) if said else ("ok", "")


def judged_status(page: Path, judged: Judged, status: str, message: str) -> tuple[str, str]:
    """Status and message once the judge's verdicts are in: a test cell whose output
    claimed a pass the judge did not give is named, and the submission is 'tampered'."""
    if judged.broken:  # the grader's own failure: never an accusation
        said = (
            "The grader could not check these cells, so they score nothing until your "
            "instructor regrades: "
            + "; ".join(f"{gid} ({judged.messages[gid]})" for gid in judged.broken)
        )
        add_notice(page, "Cells the grader could not check", said, "error")
        status, message = "error", f"{message} {said}".strip()
    if not judged.claimed:
        return status, message
    said = (
        "These test cells reported a pass in your notebook, but the grader's own check "
        "of your code failed, so they score nothing: "
        + "; ".join(f"{gid} ({judged.messages[gid]})" for gid in judged.claimed)
        + ". Your instructor sees this submission marked 'tampered'."
    )
    add_notice(page, "Checks that passed only inside your notebook", said, "tampered")
    return "tampered", f"{message} {said}".strip()


def run_job(job: Job) -> Result:
    """Grade ``job`` with its environment and its output sent to its own log."""
    os.environ.update(job.env)
    if job.log:
        log_fd = os.open(job.log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(log_fd, 1)
        os.dup2(log_fd, 2)
        os.close(log_fd)
    try:
        return grade(job)
    except Exception:  # the grader's own failure on this submission: report, go on
        return Result(
            0,
            0,
            "error",
            "The grader failed on this submission:\n"
            + "\n".join(traceback.format_exc().strip().splitlines()[-6:]),
        )


def serve(result_fd: int) -> None:
    """Read jobs from stdin until it closes; answer each on ``result_fd``."""
    # A grader started as a background job (`cmd &` in a script, `nohup`) has SIGINT
    # ignored, and so would everything it starts: the checks' Ctrl-C would then reach a
    # student's node as rclpy's ExternalShutdownException, not KeyboardInterrupt, and a
    # talker that stops cleanly in a terminal would be judged wrong. What this starts
    # gets a terminal's Ctrl-C, however the grader was started.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    with os.fdopen(result_fd, "w", buffering=1) as results:
        try:
            for line in sys.stdin:
                if line.strip():
                    result = run_job(Job(**json.loads(line)))
                    results.write(json.dumps(asdict(result)) + "\n")
        finally:
            kernels.discard_spare()  # started for a job that never came


if __name__ == "__main__":
    serve(int(sys.argv[1]))
