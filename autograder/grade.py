"""Grade a class: every submission isolated, in parallel, and every one gets a row.

``SUBMISSIONS/<student_id>/<assignment_id>/<assignment_id>.ipynb`` is nbgrader's
submitted layout. Each submission is graded by its own worker process in its own
scratch course directory and ROS domain, under a wall-clock limit; whatever it
started is killed afterwards. A broken submission costs its own row, never the batch.
"""

from __future__ import annotations

import csv
import json
import os
import queue
import select
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path

import nbformat
from nbgrader.api import Gradebook

from autograder.config import lab_ids
from autograder.course import generate
from autograder.feedback import write_notice_page
from autograder.worker import Job
from rosbook.isolation import RUN_MARKER, child_env, kill_marked, kill_process_group, reserve_domain

STATUSES = ("ok", "timeout", "error", "missing", "tampered")
CSV_HEADER = ["student_id", "assignment_id", "score", "max_score", "status"]


@dataclass
class Row:
    student_id: str
    assignment_id: str
    score: float
    max_score: float
    status: str
    message: str = ""
    seconds: float = 0.0


class GradingError(Exception):
    """The grading command itself was called wrongly (not a student's mistake)."""


@dataclass
class Assignment:
    assignment_id: str
    template: Path
    notebook: str
    max_score: float


def prepare(assignment_id: str, work: Path) -> Assignment:
    """Generate the assignment once: the gradebook (with hidden tests) and release."""
    template = work / "template" / assignment_id
    released = generate(template, assignment_id)
    notebooks = sorted(p.name for p in released.glob("*.ipynb"))
    if len(notebooks) != 1:
        raise GradingError(f"{assignment_id} must have exactly one notebook, has {notebooks}")
    with Gradebook(f"sqlite:///{template / 'gradebook.db'}") as gb:
        max_score = float(gb.find_assignment(assignment_id).max_score)
    return Assignment(assignment_id, template, notebooks[0], max_score)


def grade_one(
    slot: WorkerSlot,
    assignment: Assignment,
    student_id: str,
    submissions: Path,
    out: Path,
    work: Path,
    cell_timeout: int,
    submission_timeout: float,
) -> Row:
    """Grade one student's assignment; always returns a row, never raises for bad input."""
    aid = assignment.assignment_id
    started = time.monotonic()
    folder = submissions / student_id / aid
    notebook = folder / assignment.notebook
    feedback = out / "feedback" / student_id / aid / (Path(assignment.notebook).stem + ".html")

    def finish(score: float, status: str, message: str = "") -> Row:
        if status not in ("ok",) and not feedback.exists():
            title = {"missing": "No submission", "timeout": "Grading stopped"}.get(
                status, "Could not grade"
            )
            write_notice_page(feedback, student_id, aid, title, message, status)
        return Row(
            student_id,
            aid,
            score,
            assignment.max_score,
            status,
            message,
            round(time.monotonic() - started, 2),
        )

    if not notebook.is_file():
        found = sorted(p.name for p in folder.glob("*")) if folder.is_dir() else []
        seen = f" The folder holds: {', '.join(found)}." if found else ""
        where = f"{student_id}/{aid}/{assignment.notebook}"
        return finish(0, "missing", f"Expected the notebook {where}; it was not submitted.{seen}")
    try:
        nbformat.read(notebook, as_version=4)
    except Exception as exc:  # not JSON, or not a notebook: say what is wrong
        detail = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        return finish(
            0,
            "error",
            f"{assignment.notebook} is not a valid notebook: {detail}. "
            "Was it saved from Jupyter, or edited by hand?",
        )

    scratch = work / "runs" / student_id / aid
    scratch.mkdir(parents=True)
    log_file = out / "logs" / student_id / f"{aid}.log"
    log_file.parent.mkdir(parents=True, exist_ok=True)
    with reserve_domain() as domain:
        job = Job(
            str(assignment.template),
            aid,
            student_id,
            str(folder),
            assignment.notebook,
            str(scratch / "course"),
            str(feedback),
            cell_timeout,
            env=domain.env({}),
            log=str(log_file),
        )
        result = slot.run(job, submission_timeout)
    if result is None:
        return finish(
            0,
            "timeout",
            f"Grading was stopped after {submission_timeout:.0f} s: "
            "the notebook as a whole ran too long (a cell that never ends, or "
            "many slow ones). No score could be computed.",
        )
    return finish(result["score"], result["status"], result["message"])


class WorkerSlot:
    """One long-lived worker process; replaced when it has to be killed."""

    def __init__(self) -> None:
        self.proc: subprocess.Popen[bytes] | None = None
        self.results: int | None = None

    def _start(self) -> None:
        read_end, write_end = os.pipe()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "autograder.worker", str(write_end)],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            pass_fds=(write_end,),
            start_new_session=True,
            env=child_env(),
        )
        os.close(write_end)
        self.results = read_end

    def run(self, job: Job, timeout: float) -> dict[str, object] | None:
        """The worker's result for ``job``, or None when it overran ``timeout``."""
        if self.proc is None or self.proc.poll() is not None:
            self.stop()
            self._start()
        assert self.proc is not None and self.proc.stdin is not None
        self.proc.stdin.write((json.dumps(asdict(job)) + "\n").encode())
        self.proc.stdin.flush()
        line = self._read_line(timeout)
        token = job.env[RUN_MARKER]
        if line is None:
            self.stop()
            kill_marked(token)
            return None
        kill_marked(token, exclude={self.proc.pid})  # the kernel and the nodes it started
        if not line:  # the worker itself died
            self.stop()
            tail = "\n".join(Path(job.log).read_text(errors="replace").splitlines()[-10:])
            return {
                "score": 0,
                "status": "error",
                "message": f"The grader's worker died on this submission:\n{tail}",
            }
        return json.loads(line)

    def _read_line(self, timeout: float) -> bytes | None:
        """One line from the worker; b"" when it died, None on timeout."""
        assert self.results is not None
        deadline = time.monotonic() + timeout
        buffer = b""
        while not buffer.endswith(b"\n"):
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return None
            ready, _, _ = select.select([self.results], [], [], remaining)
            if ready:
                chunk = os.read(self.results, 65536)
                if not chunk:
                    return b""
                buffer += chunk
        return buffer

    def stop(self) -> None:
        if self.proc is not None:
            if self.proc.stdin is not None:
                self.proc.stdin.close()
            kill_process_group(self.proc)
            self.proc = None
        if self.results is not None:
            os.close(self.results)
            self.results = None


def discover(submissions: Path, assignment_id: str | None) -> tuple[list[str], list[str]]:
    if not submissions.is_dir():
        raise GradingError(
            f"{submissions} is not a folder of submissions "
            "(expected SUBMISSIONS/<student_id>/<assignment_id>/<notebook>.ipynb)"
        )
    students = sorted(
        p.name for p in submissions.iterdir() if p.is_dir() and not p.name.startswith(".")
    )
    known = lab_ids()
    if assignment_id is not None:
        if assignment_id not in known:
            raise GradingError(
                f"unknown assignment {assignment_id!r}; the labs are: " + ", ".join(known)
            )
        return students, [assignment_id]
    found = sorted(
        {
            p.name
            for s in students
            for p in (submissions / s).iterdir()
            if p.is_dir() and p.name in known
        }
    )
    if not found:
        raise GradingError(
            f"no folder in {submissions}/<student_id>/ is named after a lab "
            f"({', '.join(known)}); pass --assignment"
        )
    return students, found


def write_grades(rows: list[Row], out: Path) -> Path:
    path = out / "grades.csv"
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(CSV_HEADER)
        for r in sorted(rows, key=lambda r: (r.student_id, r.assignment_id)):
            writer.writerow(
                [r.student_id, r.assignment_id, f"{r.score:g}", f"{r.max_score:g}", r.status]
            )
    return path


def grade_class(
    submissions: Path,
    out: Path,
    assignment_id: str | None = None,
    workers: int = 2,
    cell_timeout: int = 30,
    submission_timeout: float = 600.0,
) -> list[Row]:
    """Grade every student's submissions; write grades.csv, feedback and logs to ``out``."""
    students, assignment_ids = discover(submissions, assignment_id)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="rosbook-grade-") as tmp:
        work = Path(tmp)
        assignments = [prepare(aid, work) for aid in assignment_ids]
        tasks = [(a, s) for s in students for a in assignments]
        slots: queue.Queue[WorkerSlot] = queue.Queue()
        for _ in range(max(1, workers)):
            slots.put(WorkerSlot())

        def run(task: tuple[Assignment, str]) -> Row:
            slot = slots.get()
            try:
                return grade_one(
                    slot, task[0], task[1], submissions, out, work, cell_timeout, submission_timeout
                )
            finally:
                slots.put(slot)

        try:
            with ThreadPoolExecutor(max_workers=max(1, workers)) as pool:
                rows = list(pool.map(run, tasks))
        finally:
            while not slots.empty():
                slots.get().stop()
    write_grades(rows, out)
    (out / "report.json").write_text(json.dumps([asdict(r) for r in rows], indent=1))
    return rows
