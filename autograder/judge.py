"""The judge: a trusted process that decides test cells by observing the student's code.

A test cell runs in the student's kernel, after the student's cells, so anything it
prints or asserts is the student's to change (an input transformer can turn it into
``pass``). The judge is a separate process, started by the grading worker with
``python -I -m autograder.judge <assignment>`` (``-I``: the submission's folder is never
on its ``sys.path``), that sees the student's code only through what it cannot forge:

- ROS traffic: it is started on the kernel's DDS network (the sandbox's), publishes the
  stimuli and ``/clock`` itself and records what arrives on its own subscriptions;
- return values: it asks the kernel, over a Jupyter client of its own, to build and
  spin the student's node (the agent, ``rosbook.labs.agent``) and decodes what comes
  back as plain data;
- programs: it starts the student's scripts itself, inside the kernel's sandbox and as
  the student (``student_wrap``), and reads their exit codes.

What it runs is each test cell's own source, as the instructor's notebook holds it
(hidden tests included), after the notebook's setup cells; the student's names the cell
reads are handles into the kernel (``rosbook.labs.remote``). Hidden parameters live only
there, never in the kernel. Protocol: one JSON request per line on stdin
(``{"assignment", "check": <grade_id>, "connection_file", "folder", "source", "setup"}``),
one JSON ``Verdict`` per line on stdout. The judge never imports the student's code.
"""

from __future__ import annotations

import ast
import importlib
import json
import os
import sys
import time
import traceback
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import nbformat
from nbformat import NotebookNode

from autograder import sandbox
from autograder.config import SOLUTIONS
from autograder.feedback import is_test_cell
from rosbook.labs import remote
from rosbook.labs.probes import TimedOut, rclpy_raced
from rosbook.labs.remote import JudgeTimeout, Kernel
from rosbook.runtime.session import ros

#: Wall-clock guard on one verdict (a hang guard: hitting it is a "timeout"), or the
#: cell's own limit when that is longer (``verdicts.verdict_guard``).
VERDICT_GUARD_S = 300.0
#: A cell whose first run hit a guard sooner than this runs once more (both runs fit
#: in the guard on its verdict as long as the second is no slower than twice the first).
RETRY_WITHIN_S = VERDICT_GUARD_S / 3


@dataclass
class Verdict:
    """The judge's decision on one test cell."""

    grade_id: str
    passed: bool
    message: str = ""
    timeout: bool = False
    #: The judge itself failed (a bug of the grader's, not the student's): no verdict.
    broken: bool = False
    #: What the check showed of the runs it judged (nbformat ``display_data`` outputs,
    #: figures of the lab's ``show_*``), in order: the cell's output shows them.
    outputs: list[dict[str, Any]] = field(default_factory=list)


def shared_env(assignment_id: str, folder: Path) -> dict[str, str]:
    """What the judge of ``assignment_id`` makes once for a whole grading run (the
    ``share(folder)`` of its judge module, or of the checks module its notebook's setup
    imports: lab 6's reference build), as the environment that gives
    it, read-only, to every sandbox of the run (``sandbox.SHARED_ENV``); empty for a lab
    that shares nothing, or whose share failed (each submission then makes its own, and
    the class is graded as before). The grader makes it, never a student's code."""
    share = lab_module_hook(source_setup(assignment_id), "share")
    if share is None:
        return {}
    folder.mkdir(parents=True, exist_ok=True)
    folder = folder.resolve()  # the path sandboxes see it at: no link on the way
    try:
        share(folder)
    except Exception as exc:  # noqa: BLE001 - never a reason to stop a class's grading
        said = f"{assignment_id}: nothing shared ({exc}); each submission builds its own"
        print(said, file=sys.stderr, flush=True)
        return {}
    return {sandbox.SHARED_ENV: str(folder)}


# Two ways honest code fails on Ctrl-C; a run that met either is tried once more.
# - rclpy's own race (``rclpy_raced``): its signal handler shuts the context down from a
#   thread of its own, while spin() builds its next wait set (RCLPY_SIGINT_RACE), or
#   while main's ``rclpy.try_shutdown()`` does so too, between its "is it up?" and its
#   shutdown (seen with rosbook.demos.nodes under stress); ``rosbook.labs.probes``.
# - Fast DDS's teardown hang (about once in 100 runs of three nodes stopped together on a
#   loaded machine): ``destroy_node()`` never returns. Fast DDS deletes the participant
#   with ``set_listener(nullptr)``, which waits for a discovery callback in flight
#   (another node leaving at that moment); in the wheels' build that wait spins holding
#   the lock the callback needs to finish (eProsima/Fast-DDS#6513), until SIGKILL.
#   rmw_fastrtps_cpp destroys a context's participant with its last node: a judge whose
#   nodes all went while another process's nodes started or stopped met it too (lab 6:
#   "the judge gave no verdict" on a two-robot launch); such a judge holds its
#   participant (its checks module's ``HOLD_PARTICIPANT``).


# -- a test cell, run as the instructor wrote it ---------------------------------------

#: The file name a test cell's code runs under in the judge (its frames in tracebacks).
CELL_FILE = "<test cell>"


def setup_cells(notebook: NotebookNode) -> list[str]:
    """The source of the notebook's setup cells: the instructor's read-only code cells
    (nbgrader ``locked``, neither a task nor a test), which a test cell may rely on
    (imports, ``checks``, a given URDF). The judge runs them itself."""
    found = []
    for cell in notebook.cells:
        meta = cell.get("metadata", {}).get("nbgrader", {})
        if cell.cell_type == "code" and meta.get("locked") and not meta.get("grade"):
            if not meta.get("solution"):
                found.append(cell.source)
    return found


def bound_names(tree: ast.AST) -> set[str]:
    """Every name ``tree`` binds anywhere (assignments, imports, definitions, arguments)."""
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and isinstance(node.ctx, (ast.Store, ast.Del)):
            names.add(node.id)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, ast.arg):
            names.add(node.arg)
        elif isinstance(node, ast.ExceptHandler) and node.name:
            names.add(node.name)
    return names


def free_names(tree: ast.AST) -> set[str]:
    """The names ``tree`` reads but never binds, builtins left out: the setup's names
    and the student's."""
    import builtins

    read = {
        node.id
        for node in ast.walk(tree)
        if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Load)
    }
    return read - bound_names(tree) - set(dir(builtins))


def lab_imports(setup: list[str]) -> dict[str, str]:
    """The names the setup cells bind to a ``rosbook.labs`` module (``checks``), and the
    module each names. The setup is read, not run: the grader asks before any kernel
    runs (``shared_env``)."""
    found: dict[str, str] = {}
    for source in setup:
        try:
            tree = ast.parse(source)
        except SyntaxError:
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module == "rosbook.labs":
                found |= {a.asname or a.name: f"rosbook.labs.{a.name}" for a in node.names}
            elif isinstance(node, ast.Import):
                found |= {
                    a.asname: a.name
                    for a in node.names
                    if a.asname and a.name.startswith("rosbook.labs.")
                }
    return found


def calls_checks(source: str, setup: list[str]) -> bool:
    """Whether test cell ``source`` (as the kernel gets it) calls the lab's checks: its
    run in the kernel is then deferred (``rosbook.labs.deferral``), and passes there only
    if forged. A cell that calls none can pass in the kernel honestly."""
    aliases = set(lab_imports(setup))
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return False
    return any(
        isinstance(node, ast.Attribute)
        and isinstance(node.value, ast.Name)
        and node.value.id in aliases
        for node in ast.walk(tree)
    )


def parse_cell(source: str) -> ast.Module:
    """A test cell's code; ``SyntaxError`` (with what to do) for IPython's own syntax
    (``%magic``, ``!shell``), which only a kernel runs."""
    try:
        return ast.parse(source, CELL_FILE)
    except SyntaxError as exc:
        line = (exc.text or "").strip()
        if line.startswith(("%", "!")):
            raise SyntaxError(
                f"line {exc.lineno} is IPython syntax ({line.split()[0]}), which the judge "
                "cannot run outside the kernel: write it as Python"
            ) from None
        raise


def unjudged_cells(assignment_id: str, notebook: NotebookNode) -> list[str]:
    """``<lab>: test cell <grade_id>: <why>`` for each test cell of ``notebook`` (the
    lab's source) that the judge cannot run outside the kernel: one that is not Python,
    or uses a name that neither the setup cells nor the student's cells define."""
    defined: set[str] = set()
    for cell in notebook.cells:
        if cell.cell_type == "code" and not is_test_cell(cell):
            try:
                defined |= bound_names(ast.parse(cell.source))
            except SyntaxError:  # a %%writefile cell, a magic: binds no Python name
                continue
    found = []
    for cell in notebook.cells:
        if not is_test_cell(cell):
            continue
        grade_id = cell.metadata.nbgrader.get("grade_id", "")
        try:
            tree = parse_cell(cell.source)
        except SyntaxError as exc:
            found.append(f"{assignment_id}: test cell {grade_id}: {exc.msg}")
            continue
        unknown = sorted(free_names(tree) - defined)
        if unknown:
            found.append(
                f"{assignment_id}: test cell {grade_id}: uses {', '.join(unknown)}, which no "
                "cell of the notebook defines (the judge runs the test cell outside the "
                "kernel, with the setup cells' names and the student's)"
            )
    return found


_setups: dict[str, dict[str, Any]] = {}


def setup_namespace(sources: list[str]) -> dict[str, Any]:
    """The names the setup cells ``sources`` define, run once in the judge (a copy each
    time: a test cell's assignments never reach the next)."""
    key = "\0".join(sources)
    if key not in _setups:
        namespace: dict[str, Any] = {"__name__": "__judge_setup__"}
        for source in sources:
            exec(compile(source, "<setup cell>", "exec"), namespace)  # noqa: S102 (the instructor's)
        _setups[key] = namespace
    return dict(_setups[key])


def student_wrap(sandbox_pid: int | None, folder: Path) -> Callable[[list[str]], list[str]]:
    """What runs a command where the student's code runs: in the kernel's sandbox, as
    the student (its paths as the judge sees them, through ``/proc/<pid>/root``)."""
    if sandbox_pid is None:  # an unsandboxed kernel (the student's own self-check)
        return list
    outside = f"/proc/{sandbox_pid}/root"

    def inside(path: str) -> str:
        return path[len(outside) :] if path.startswith(outside + "/") else path

    def wrap(argv: list[str]) -> list[str]:
        return sandbox.enter_argv(sandbox_pid, inside(str(folder)), [inside(a) for a in argv])

    return wrap


def lab_module_hook(setup: list[str], name: str) -> Any:
    """``name`` of the lab's checks module (a ``rosbook.labs`` module the setup imports),
    or None: a lab's own settings for its judge (``HOLD_PARTICIPANT``, ``share``)."""
    for module in lab_imports(setup).values():
        value = getattr(importlib.import_module(module), name, None)
        if value is not None:
            return value
    return None


def source_setup(assignment_id: str) -> list[str]:
    """The setup cells of the instructor's source notebook of ``assignment_id``
    (``solutions/``); none for a lab that has none there."""
    path = SOLUTIONS / assignment_id / f"{assignment_id}.ipynb"
    return setup_cells(nbformat.read(path, as_version=4)) if path.is_file() else []


def prepare(assignment_id: str) -> None:
    """Run the setup cells of ``assignment_id``'s source notebook and import the modules
    its checks module names in ``PRELOAD`` (what its figures are made with), while the
    kernel starts and the student's cells run: the first test cell finds them done. A
    failure here is the first test cell's to say."""
    try:
        setup = source_setup(assignment_id)
        setup_namespace(setup)
        for name in lab_module_hook(setup, "PRELOAD") or ():
            importlib.import_module(name)
    except Exception:  # noqa: S110 - the test cell runs the setup again and says why
        pass


def run_cell(j: remote.Judgement, source: str, setup: list[str]) -> None:
    """Run test cell ``source`` against the kernel of ``j``: the setup's names, and the
    student's names it reads bound to the kernel's (``Judgement.bind``)."""
    tree = parse_cell(source)
    namespace = setup_namespace(setup)
    namespace.update(j.bind(sorted(free_names(tree) - set(namespace))))
    with remote.judging_cell(j):
        exec(compile(tree, CELL_FILE, "exec"), namespace)  # noqa: S102 (the instructor's cell)


def _in_cell(exc: BaseException) -> int | None:
    """The line of the test cell where ``exc`` was raised, if it was raised by the
    cell's own code (not inside a check helper)."""
    frames = traceback.extract_tb(exc.__traceback__)
    return frames[-1].lineno if frames and frames[-1].filename == CELL_FILE else None


def judge_cell(request: dict[str, Any], kernel: Kernel) -> Verdict:
    """The verdict on one test cell, run in the judge as its source says."""
    grade_id = request["check"]
    folder = Path(request["folder"])
    setup = list(request.get("setup", []))
    j = remote.Judgement(
        kernel,
        folder,
        student_wrap(request.get("sandbox_pid"), folder),
        cell_timeout=request.get("cell_timeout"),
    )
    held = bool(lab_module_hook(setup, "HOLD_PARTICIPANT"))
    try:
        if held:
            ros.hold_participant()
        for attempt in (1, 2):
            started = time.monotonic()
            try:
                run_cell(j, request["source"], setup)
                break
            except (JudgeTimeout, TimedOut, TimeoutError) as exc:
                # A guard was hit: a hang, a starved machine, or a DDS participant that
                # once in a while takes a minute to end. The cell once more, from where
                # it began, if that fits the grader's guard on a verdict: a second
                # timeout is the verdict.
                if attempt == 2 or time.monotonic() - started > RETRY_WITHIN_S:
                    raise
                said = str(exc).removeprefix("timeout: ")
                print(f"[judge] {grade_id}: timeout: {said}; the cell once more", flush=True)
                j.outputs.clear()
                undo(j, grade_id, kernel)
            except AssertionError as exc:
                if attempt == 2 or not rclpy_raced(str(exc)):
                    raise
                j.outputs.clear()  # rclpy's own Ctrl-C race: the cell once more
                ros.reset()
        return Verdict(grade_id, True, outputs=j.outputs)
    except (JudgeTimeout, TimedOut, TimeoutError) as exc:  # a hang guard, not a verdict
        said = str(exc).removeprefix("timeout: ")
        return Verdict(grade_id, False, f"timeout: {said}", timeout=True, outputs=j.outputs)
    except NameError as exc:
        said = f"{exc.name} is not defined: write it in its task's cell and run it"
        return Verdict(grade_id, False, said, outputs=j.outputs)
    except AssertionError as exc:
        line = _in_cell(exc)
        said = str(exc) or f"a check of this cell failed (line {line})"
        return Verdict(grade_id, False, said, outputs=j.outputs)
    except Exception as exc:  # the cell's own code on a wrong value: a failure
        if _in_cell(exc) is not None:
            said = f"{type(exc).__name__}: {exc} (line {_in_cell(exc)} of the test)"
            return Verdict(grade_id, False, said, outputs=j.outputs)
        tail = "\n".join(traceback.format_exc().strip().splitlines()[-4:])
        return Verdict(grade_id, False, f"the judge failed on this check:\n{tail}", broken=True)
    finally:
        undo(j, grade_id, kernel)
        if not held:
            ros.hold_participant(False)


def undo(j: remote.Judgement, grade_id: str, kernel: Kernel) -> None:
    """Undo what a run of test cell ``grade_id`` left: its checks' leftovers, the judge's
    ROS entities and simulated time, the nodes it started in the kernel."""
    try:
        j.ends.close()
    except Exception as exc:  # noqa: BLE001 - after the verdict: said, never raised
        print(f"[judge] {grade_id}: undoing the cell's work failed: {exc}", flush=True)
    ros.reset()
    if ros.sim_time:
        ros.init(sim_time=False)
    try:
        kernel.call("stop", guard=10.0)
    except Exception:  # noqa: S110 - the kernel's state is the student's
        pass


# -- the process ---------------------------------------------------------------------


def judge_one(request: dict[str, Any], kernels: dict[str, Kernel]) -> Verdict:
    kernel = kernels.get(request["connection_file"])
    if kernel is None:
        kernel = kernels[request["connection_file"]] = Kernel(request["connection_file"])
    return judge_cell(request, kernel)


@contextmanager
def _stdout_for_verdicts() -> Iterator[Any]:
    """Verdicts travel on the original stdout; everything else printed goes to stderr
    (rcl's log lines write to file descriptor 1)."""
    verdicts = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)
    try:
        yield verdicts
    finally:
        verdicts.close()


def serve(assignment_id: str | None = None) -> None:
    """Answer requests until stdin ends. With ``assignment_id`` (the grader's), the
    lab's checks and the modules they show figures with (its ``PRELOAD``) are imported
    first, while the kernel starts and the student's cells run (``prepare``)."""
    ros.init()
    if assignment_id is not None:
        prepare(assignment_id)
    kernels: dict[str, Kernel] = {}
    with _stdout_for_verdicts() as verdicts:
        try:
            for line in sys.stdin:
                if line.strip():
                    started = time.monotonic()
                    verdict = judge_one(json.loads(line), kernels)
                    took = time.monotonic() - started
                    said = f": {verdict.message.splitlines()[0][:300]}" if verdict.message else ""
                    print(
                        f"[judge] {verdict.grade_id}: {verdict.passed} in {took:.2f} s{said}",
                        flush=True,
                    )
                    verdicts.write(json.dumps(asdict(verdict)) + "\n")
        finally:
            for kernel in kernels.values():
                kernel.close()
            ros.shutdown()


if __name__ == "__main__":
    # Run the module's own copy (not ``__main__``'s), so the checks' exceptions are the
    # classes ``judge_one`` catches.
    from autograder import judge

    judge.serve(sys.argv[1] if len(sys.argv) > 1 else None)
