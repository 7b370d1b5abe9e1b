"""Grade a class: every submission isolated, in parallel, and every one gets a row.

``SUBMISSIONS/<student_id>/<assignment_id>/<assignment_id>.ipynb`` is nbgrader's
submitted layout. Each submission is graded by its own worker process in its own
scratch course directory and ROS domain, under a wall-clock limit; whatever it
started is killed afterwards. A broken submission costs its own row, never the batch.
"""

from __future__ import annotations

import atexit
import contextlib
import hashlib
import itertools
import json
import os
import queue
import select
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TextIO

import nbformat
from nbgrader.api import Gradebook

from autograder import preflight
from autograder.config import CELL_TIMEOUT_S, SOLUTIONS, lab_ids
from autograder.course import generate
from autograder.feedback import GRADER_ERROR, write_notice_page
from autograder.gradebook import CellComment, CellGrade, add_assignment, read_scratch
from autograder.gradebook import record as record_in_gradebook
from autograder.judge import shared_env
from autograder.progress import Progress
from autograder.results import Journal, folder_digest, write_atomic, write_tables
from autograder.worker import Job, refusal
from rosbook.launch.launcher import _die_with_launcher as die_with_parent
from rosbook.runtime.interrupts import ctrl_c_held
from rosbook.runtime.isolation import (
    RUN_MARKER,
    DomainReservation,
    child_env,
    kill_marked,
    kill_orphans,
    kill_process_group,
    reserve_domain,
)

STATUSES = ("ok", "timeout", "error", "missing", "tampered", GRADER_ERROR)
Files = dict[str, bytes]  # a submission folder's files by relative path


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
    digest: str  # of the lab's source: a changed lab is graded again on --resume
    env: dict[str, str] = field(default_factory=dict)  # what its judge shares (shared_env)


def prepare(assignment_id: str, work: Path, out: Path | None = None) -> Assignment:
    """Generate the assignment once: the gradebook (with hidden tests) and release.

    With ``out``, the assignment is also put in the course gradebook there.
    """
    template = work / "template" / assignment_id
    released = generate(template, assignment_id)
    notebooks = sorted(p.name for p in released.glob("*.ipynb"))
    if len(notebooks) != 1:
        raise GradingError(f"{assignment_id} must have exactly one notebook, has {notebooks}")
    with Gradebook(f"sqlite:///{template / 'gradebook.db'}") as gb:
        max_score = float(gb.find_assignment(assignment_id).max_score)
    digest = folder_digest(SOLUTIONS / assignment_id)
    if out is not None:
        add_assignment(out, template, assignment_id, digest)
    env = shared_env(assignment_id, work / "shared" / assignment_id)
    return Assignment(assignment_id, template, notebooks[0], max_score, digest, env)


@dataclass
class Graded:
    """One graded submission: its row and everything written to OUT for it."""

    row: Row
    grades: list[CellGrade] | None  # None: nbgrader produced no scores
    comments: list[CellComment]
    feedback: bytes
    log: bytes
    autograded: bytes | None  # the notebook as nbgrader graded it (for formgrader)


#: The key of ``Files`` under which ``read_submission`` says why it read nothing: a name
#: no file can have.
REFUSED = "\0refused"


def read_submission(
    submissions: Path, student_id: str, assignment_id: str, notebook: str
) -> Files | None:
    """The files of a student's assignment folder, by relative path; None without one.

    Links are never followed (a link to /etc/passwd or to another student's notebook is
    not the student's work): a linked notebook or folder, or a huge notebook, is refused
    unread (``{REFUSED: why}``); any other link is left out.
    """
    folder = submissions / student_id / assignment_id
    if not folder.is_dir():
        return None
    why = refusal(folder, notebook) if os.path.lexists(folder / notebook) else None
    if why:
        return {REFUSED: why.encode()}
    files: Files = {}
    for top, _dirs, names in os.walk(folder):  # does not descend into linked folders
        for name in names:
            path = Path(top) / name
            if path.is_file() and not path.is_symlink():
                files[str(path.relative_to(folder))] = path.read_bytes()
    return dict(sorted(files.items()))


def grade_one(
    slot: WorkerSlot,
    assignment: Assignment,
    student_id: str,
    files: Files | None,
    work: Path,
    cell_timeout: int,
    submission_timeout: float,
    ahead: bool = True,
) -> Graded:
    """Grade one student's assignment; always returns a result, never raises for bad input.

    ``files`` is the student's assignment folder (None when there is none). Everything
    happens in a scratch folder under ``work`` that is removed afterwards, and every
    output comes back as data: the same call grades locally and on a Dask worker.
    ``ahead``: the slot will likely grade another submission (its kernel is started
    ahead, at the end of this one: ``WorkerSlot``).
    """
    aid = assignment.assignment_id
    started = time.monotonic()
    (work / "runs").mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix=f"{student_id}-{aid}-", dir=work / "runs"))
    feedback = scratch / "feedback.html"
    log_file = scratch / "grading.log"
    log_file.touch()

    def finish(
        score: float, status: str, message: str = "", grades: list[CellGrade] | None = None
    ) -> Graded:
        if not feedback.exists():
            title = {"missing": "No submission", "timeout": "Grading stopped"}.get(
                status, "Could not grade"
            )
            write_notice_page(feedback, student_id, aid, title, message, status)
        comments: list[CellComment] = []
        autograded: bytes | None = None
        if grades is not None:
            grades, comments = read_scratch(scratch / "course", aid, student_id)
            graded_nb = scratch / "course" / "autograded" / student_id / aid / assignment.notebook
            autograded = graded_nb.read_bytes() if graded_nb.is_file() else None
        row = Row(
            student_id,
            aid,
            score,
            assignment.max_score,
            status,
            message,
            round(time.monotonic() - started, 2),
        )
        graded = Graded(
            row, grades, comments, feedback.read_bytes(), log_file.read_bytes(), autograded
        )
        shutil.rmtree(scratch, ignore_errors=True)
        return graded

    refused = (files or {}).get(REFUSED)
    if refused is not None:  # a link or a huge file: never read, never followed
        return finish(0, "error", refused.decode())
    notebook_bytes = (files or {}).get(assignment.notebook)
    if notebook_bytes is None:
        found = sorted(files or {})
        seen = f" The folder holds: {', '.join(found)}." if found else ""
        where = f"{student_id}/{aid}/{assignment.notebook}"
        return finish(0, "missing", f"Expected the notebook {where}; it was not submitted.{seen}")
    try:
        nbformat.reads(notebook_bytes.decode("utf-8", errors="replace"), as_version=4)
    except Exception as exc:  # not JSON, or not a notebook: say what is wrong
        detail = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        return finish(
            0,
            "error",
            f"{assignment.notebook} is not a valid notebook: {detail}. "
            "Was it saved from Jupyter, or edited by hand?",
        )

    folder = scratch / "submission"
    for name, data in (files or {}).items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(data)
    domain, following = slot.domains(ahead)
    with domain:
        job = Job(
            str(assignment.template),
            aid,
            student_id,
            str(folder),
            assignment.notebook,
            str(scratch / "course"),
            str(feedback),
            cell_timeout,
            env=domain.env(assignment.env),
            # most likely the same lab's (a kernel started for another's is not used)
            next_env=following.env(assignment.env) if following else {},
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
    scored = float(result.get("max_score", 0)) > 0  # nbgrader recorded per-cell grades
    return finish(result["score"], result["status"], result["message"], [] if scored else None)


#: How long an idle worker is given to end on its own once told there is no more work.
IDLE_STOP_S = 10.0


def start_slots(workers: int) -> list[WorkerSlot]:
    """``workers`` (at least one) worker processes, started: they import while we go on."""
    slots = [WorkerSlot() for _ in range(max(1, workers))]
    for slot in slots:
        slot.start()
    return slots


class WorkerSlot:
    """One long-lived worker process; replaced when it has to be killed.

    Each job also tells the worker the ROS domain of the slot's next job, reserved
    with it, so that the worker can start that job's kernel ahead (``kernels.Spare``).
    """

    def __init__(self) -> None:
        self.proc: subprocess.Popen[bytes] | None = None
        self.results: int | None = None
        self.next_domain: DomainReservation | None = None
        self.busy = False  # a job was sent and its answer not yet read

    def domains(self, ahead: bool) -> tuple[DomainReservation, DomainReservation | None]:
        """The domain of the job about to run (the one reserved for it with the slot's
        last job, if this worker runs on) and, if ``ahead``, one reserved for the slot's
        next job."""
        current = self.next_domain or reserve_domain()
        self.next_domain = reserve_domain() if ahead else None
        return current, self.next_domain

    def start(self) -> None:
        read_end, write_end = os.pipe()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "autograder.worker", str(write_end)],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            pass_fds=(write_end,),
            start_new_session=True,
            preexec_fn=die_with_parent,  # a grader killed with SIGKILL takes it along
            env=child_env(),
        )
        os.close(write_end)
        self.results = read_end
        self.busy = False

    def run(self, job: Job, timeout: float) -> dict[str, object] | None:
        """The worker's result for ``job``, or None when it overran ``timeout``."""
        if self.proc is None or self.proc.poll() is not None:
            self.stop()
            self.start()
        assert self.proc is not None and self.proc.stdin is not None
        self.busy = True
        self.proc.stdin.write((json.dumps(asdict(job)) + "\n").encode())
        self.proc.stdin.flush()
        line = self._read_line(timeout)
        self.busy = line is None  # overran: still at work
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
                "status": GRADER_ERROR,
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

    def abort(self) -> None:
        """Kill the worker now (from another thread): the job it runs ends as "died"."""
        proc = self.proc
        if proc is not None:
            kill_process_group(proc)

    def stop(self) -> None:
        if self.proc is not None:
            if self.proc.stdin is not None:
                self.proc.stdin.close()
            if not self.busy:  # it ends on its own, its kernel started ahead shut down
                with contextlib.suppress(subprocess.TimeoutExpired):
                    self.proc.wait(timeout=IDLE_STOP_S)
            kill_process_group(self.proc)
            self.proc = None
        if self.next_domain is not None:  # the kernel started ahead for it, if any
            kill_marked(self.next_domain.token)
            self.next_domain.release()
            self.next_domain = None
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


@dataclass
class Task:
    assignment_id: str
    student_id: str
    digest: str  # the submission folder and the lab's source: unchanged means same grade


class Interrupted(Exception):
    """The run was stopped (Ctrl-C, SIGTERM); every finished row is kept in OUT."""

    def __init__(self, done: int, total: int) -> None:
        super().__init__(f"stopped after {done} of {total} submission(s)")
        self.done = done
        self.total = total


def save(out: Path, graded: Graded, notebook: str, digest: str, journal: Journal) -> None:
    """Write one graded submission to OUT: its files, the gradebook, then its row.

    The journal line is the commit point: a row there means its files are in place.
    """
    row = graded.row
    stem = Path(notebook).stem
    write_atomic(
        out / "feedback" / row.student_id / row.assignment_id / f"{stem}.html", graded.feedback
    )
    write_atomic(out / "logs" / row.student_id / f"{row.assignment_id}.log", graded.log)
    autograded = out / "autograded" / row.student_id / row.assignment_id / notebook
    if graded.autograded is not None:
        write_atomic(autograded, graded.autograded)
    else:
        autograded.unlink(missing_ok=True)
    record_in_gradebook(
        out, row.assignment_id, row.student_id, row.status, graded.grades, graded.comments
    )
    journal.append({**asdict(row), "digest": digest})
    write_tables(journal, out)


def select_students(students: list[str], only: list[str] | None) -> list[str]:
    if not only:
        return students
    unknown = sorted(set(only) - set(students))
    if unknown:
        raise GradingError(
            f"no submissions folder for student(s) {', '.join(unknown)} "
            "(--student takes the names of folders in SUBMISSIONS)"
        )
    return [s for s in students if s in only]


def grade_class(
    submissions: Path,
    out: Path,
    assignment_id: str | None = None,
    workers: int = 2,
    cell_timeout: int = CELL_TIMEOUT_S,
    submission_timeout: float = 600.0,
    resume: bool = False,
    students: list[str] | None = None,
    progress: TextIO | None = None,
    scheduler: str | None = None,
) -> list[Row]:
    """Grade every student's submissions into ``out``; return every row ``out`` holds.

    Each submission's row, feedback, log and gradebook entry are written as soon as it
    is graded. ``resume`` keeps the rows already in ``out`` whose submission is
    unchanged; ``students`` regrades only those, leaving the others' rows as they are.
    ``scheduler`` (a Dask scheduler's address) grades on its workers instead of here.
    Raises ``Interrupted`` on Ctrl-C once what it started is stopped, and
    ``preflight.NotReady`` before grading anything when no kernel can run here.
    """
    everyone, assignment_ids = discover(submissions, assignment_id)
    if not scheduler:  # before any row: a sandbox that cannot start grades nobody
        preflight.check()
    kill_orphans()  # what a grading run killed before (SIGKILL, power loss) left behind
    chosen = select_students(everyone, students)
    out.mkdir(parents=True, exist_ok=True)
    journal = Journal(out, keep=resume or bool(students))
    try:
        with tempfile.TemporaryDirectory(prefix="rosbook-grade-") as tmp:
            work = Path(tmp)
            labs = {aid: folder_digest(SOLUTIONS / aid) for aid in assignment_ids}
            tasks = []
            for student in chosen:
                for aid, lab in labs.items():
                    digest = hashlib.sha256(
                        (lab + folder_digest(submissions / student / aid)).encode()
                    ).hexdigest()
                    tasks.append(Task(aid, student, digest))
            todo = [
                t
                for t in tasks
                if not (resume and journal.graded(t.student_id, t.assignment_id, t.digest))
            ]
            # A worker takes seconds to import nbgrader: the local ones start now and
            # import while the labs generate (on another core when there is one); no
            # more of them than there are submissions to grade.
            slots = [] if scheduler or not todo else start_slots(min(workers, len(todo)))
            try:
                # generating a lab takes seconds: only the labs with something to grade
                assignments = {
                    aid: prepare(aid, work, out) for aid in sorted({t.assignment_id for t in todo})
                }
            except BaseException:
                for slot in slots:
                    slot.stop()
                raise
            shown = Progress(len(todo), len(tasks) - len(todo), progress, len(slots))

            def saved(graded: Graded, task: Task) -> None:
                save(out, graded, assignments[task.assignment_id].notebook, task.digest, journal)
                r = graded.row
                shown.update(
                    r.student_id, r.assignment_id, f"{r.score:g}/{r.max_score:g}", r.status
                )

            try:
                if scheduler:
                    run_dask(
                        todo,
                        assignments,
                        submissions,
                        scheduler,
                        cell_timeout,
                        submission_timeout,
                        saved,
                    )
                else:
                    run_local(
                        todo,
                        assignments,
                        submissions,
                        work,
                        slots,
                        cell_timeout,
                        submission_timeout,
                        saved,
                    )
            finally:
                shown.close()
    finally:
        journal.close()
        write_tables(journal, out)
    return [Row(**{k: e[k] for k in Row.__dataclass_fields__}) for e in journal.rows()]


def run_local(
    tasks: list[Task],
    assignments: dict[str, Assignment],
    submissions: Path,
    work: Path,
    every_slot: list[WorkerSlot],
    cell_timeout: int,
    submission_timeout: float,
    saved: Callable[[Graded, Task], None],
) -> None:
    """Grade ``tasks`` with the local workers of ``every_slot``; ``saved`` each as it ends.

    The slots are stopped at the end.

    On Ctrl-C the workers are killed with what they started, the submissions being
    graded are dropped (they get no row), and ``Interrupted`` is raised.
    """
    if not tasks:  # a resumed class with nothing left to grade: no worker was started
        return
    slots: queue.Queue[WorkerSlot] = queue.Queue()
    for slot in every_slot:
        slots.put(slot)
    stopping = threading.Event()
    started = itertools.count(1)

    def run(task: Task) -> Graded | None:
        if stopping.is_set():
            return None
        slot = slots.get()
        assignment = assignments[task.assignment_id]
        # every slot still has a submission to come after this one
        ahead = len(tasks) - next(started) >= len(every_slot)
        try:
            files = read_submission(
                submissions, task.student_id, task.assignment_id, assignment.notebook
            )
            graded = grade_one(
                slot,
                assignment,
                task.student_id,
                files,
                work,
                cell_timeout,
                submission_timeout,
                ahead,
            )
        except Exception as exc:  # the grader's own failure: this submission's row says so
            detail = f"{type(exc).__name__}: {exc}"
            graded = not_graded(assignment, task.student_id, f"The grader failed: {detail}")
        finally:
            slots.put(slot)
        return None if stopping.is_set() else graded

    pool = ThreadPoolExecutor(max_workers=len(every_slot))
    done = 0
    try:
        futures = {pool.submit(run, t): t for t in tasks}
        for future in as_completed(futures):
            graded = future.result()
            if graded is not None:
                with ctrl_c_held():  # the row is saved and counted, then Ctrl-C stops us
                    saved(graded, futures[future])
                    done += 1
    except BaseException as exc:  # Ctrl-C, or OUT could not be written: stop it all now
        stopping.set()
        pool.shutdown(wait=False, cancel_futures=True)
        for slot in every_slot:
            slot.abort()
        pool.shutdown(wait=True)
        if isinstance(exc, KeyboardInterrupt):
            raise Interrupted(done, len(tasks)) from None
        raise
    finally:
        pool.shutdown(wait=True)
        for slot in every_slot:
            slot.stop()


def run_dask(
    tasks: list[Task],
    assignments: dict[str, Assignment],
    submissions: Path,
    scheduler: str,
    cell_timeout: int,
    submission_timeout: float,
    saved: Callable[[Graded, Task], None],
) -> None:
    """Grade ``tasks`` on the workers of the Dask scheduler at ``scheduler``.

    Each worker runs ``grade_on_worker``: the same ``grade_one`` as a local run. A
    worker that dies mid-submission has it retried on another (Dask's scheduler does
    that); a submission on which workers died three times gets an error row.
    """
    from distributed import Client
    from distributed import as_completed as completed_on_workers
    from distributed.scheduler import KilledWorker

    try:
        client = Client(scheduler, timeout=60)
    except OSError as exc:
        raise GradingError(f"no Dask scheduler answers at {scheduler}: {exc}") from None
    done = 0
    with client:
        run = uuid.uuid4().hex[:8]
        futures = {
            client.submit(
                grade_on_worker,
                t.assignment_id,
                assignments[t.assignment_id].digest,
                t.student_id,
                read_submission(
                    submissions,
                    t.student_id,
                    t.assignment_id,
                    assignments[t.assignment_id].notebook,
                ),
                cell_timeout,
                submission_timeout,
                key=f"grade-{run}-{t.assignment_id}-{t.student_id}",
            ): t
            for t in tasks
        }
        try:
            for future in completed_on_workers(futures):
                task = futures[future]
                try:
                    graded = future.result()
                except KilledWorker as exc:
                    graded = not_graded(
                        assignments[task.assignment_id],
                        task.student_id,
                        "The grading machines died while grading this notebook, several times "
                        f"({type(exc).__name__}); no score could be computed. Regrade it with "
                        f"--student {task.student_id} once the machines are healthy.",
                    )
                with ctrl_c_held():  # the row is saved and counted, then Ctrl-C stops us
                    saved(graded, task)
                    done += 1
        except KeyboardInterrupt:
            client.cancel(list(futures))
            raise Interrupted(done, len(tasks)) from None
        except GradingError:
            client.cancel(list(futures))
            raise


def not_graded(assignment: Assignment, student_id: str, message: str) -> Graded:
    """The ``GRADER_ERROR`` result of a submission the grader itself failed on."""
    with tempfile.TemporaryDirectory() as tmp:
        page = Path(tmp) / "feedback.html"
        write_notice_page(
            page, student_id, assignment.assignment_id, "Could not grade", message, GRADER_ERROR
        )
        feedback = page.read_bytes()
    row = Row(student_id, assignment.assignment_id, 0, assignment.max_score, GRADER_ERROR, message)
    return Graded(row, None, [], feedback, b"", None)


_on_worker: dict[str, object] = {}
_on_worker_lock = threading.Lock()


def grade_on_worker(
    assignment_id: str,
    lab_digest: str,
    student_id: str,
    files: Files | None,
    cell_timeout: int,
    submission_timeout: float,
) -> Graded:
    """One submission graded in a Dask worker, as ``grade_one`` grades it locally.

    The worker generates each lab once from its own copy of the course and keeps its
    grading processes between submissions (one per thread); no state of a student's
    run is kept: each submission gets a fresh scratch course, kernel and ROS domain.
    """
    with _on_worker_lock:
        if not _on_worker:
            work = Path(tempfile.mkdtemp(prefix="rosbook-grade-worker-"))
            atexit.register(shutil.rmtree, work, True)
            _on_worker.update(work=work, assignments={}, slots=queue.Queue())
        work = _on_worker["work"]  # type: ignore[assignment]
        prepared: dict[str, Assignment] = _on_worker["assignments"]  # type: ignore[assignment]
        if assignment_id not in prepared:
            prepared[assignment_id] = prepare(assignment_id, work)
    assignment = prepared[assignment_id]
    if assignment.digest != lab_digest:
        raise GradingError(
            f"this grading machine's copy of {assignment_id} differs from the one the grading "
            "command was started with: install the same version of the course on every machine"
        )
    kill_orphans()  # left by a worker that died here mid-submission
    slots: queue.Queue[WorkerSlot] = _on_worker["slots"]  # type: ignore[assignment]
    try:
        slot = slots.get_nowait()
    except queue.Empty:
        slot = WorkerSlot()
    try:
        return grade_one(
            slot, assignment, student_id, files, work, cell_timeout, submission_timeout
        )
    finally:
        slots.put(slot)
