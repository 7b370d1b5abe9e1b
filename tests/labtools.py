"""Build a lab's fixture submissions from its release and solution, and grade them.

Fixtures are derived from ``labs/`` and ``solutions/`` at test time, so they never go
stale when a lab changes: "right" is the release with every solution cell answered as
in the solution (``autograder.course.answered``, which the book's grading page uses
too), "wrong" replaces some answers, and so on.
"""

from __future__ import annotations

import base64
import copy
import csv
import os
import re
import shutil
import sys
from pathlib import Path

import nbformat
import pytest

from autograder.config import LABS, SOLUTIONS
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


def extra_cell(notebook: nbformat.NotebookNode, source: str, at: int = 2) -> nbformat.NotebookNode:
    """A student's own cell inserted at ``at`` (default: right after the set-up cell)."""
    notebook.cells.insert(at, nbformat.v4.new_code_cell(source))
    return notebook


#: A student's cell that prints the source of every later cell the kernel runs, as the
#: kernel gets it: before it runs and after (IPython's ``pre_run_cell`` and
#: ``post_run_cell`` events).
SOURCE_PRINTER = (
    "ip = get_ipython()\n"
    "ip.events.register('pre_run_cell', lambda info: print('PRE-RUN:', info.raw_cell))\n"
    "ip.events.register('post_run_cell', lambda result: print('POST-RUN:', result.info.raw_cell))"
)
#: A student's last cell: everything the kernel ran, from IPython's input history.
HISTORY_PRINTER = "print('HISTORY:', *In, *_ih, sep='\\n')"


def output_text(notebook: nbformat.NotebookNode) -> str:
    """Every text a notebook's cells show: streams, errors, and text/plain or HTML data."""
    texts = []
    for cell in notebook.cells:
        for output in cell.get("outputs", []):
            texts += [output.get("text", ""), output.get("evalue", "")]
            texts += output.get("traceback", [])
            data = output.get("data", {})
            texts += [data.get("text/plain", ""), data.get("text/html", "")]
    return "\n".join(t if isinstance(t, str) else "".join(t) for t in texts)


def hidden_only_lines(lab: str, solutions: Path = SOLUTIONS, labs: Path = LABS) -> list[str]:
    """The lines of ``lab``'s hidden tests (source notebook) that appear nowhere in its
    release: where one shows in a graded submission, a hidden test's source leaked."""
    source = nbformat.read(solutions / lab / f"{lab}.ipynb", as_version=4)
    released = nbformat.read(labs / lab / f"{lab}.ipynb", as_version=4)
    visible = {ln.strip() for c in released.cells for ln in c.source.splitlines()}
    hidden, inside = [], False
    for cell in source.cells:
        for line in cell.source.splitlines():
            if "BEGIN HIDDEN TESTS" in line or "END HIDDEN TESTS" in line:
                inside = "BEGIN" in line
            elif inside and line.strip() and line.strip() not in visible:
                hidden.append(line.strip())
    return hidden


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


#: Seconds: only a guard against a hung grading run, never a verdict.
HANG = 900.0


def grade_cmd(submissions: Path, out: Path, lab: str, *extra: str) -> list[str]:
    """The instructor's command that grades ``lab`` of ``submissions`` into ``out``."""
    return [
        sys.executable, "-m", "autograder", "grade", str(submissions), "--assignment", lab,
        "--out", str(out), *extra,
    ]  # fmt: skip


def grade(submissions: Path, out: Path, **kwargs: object) -> dict[tuple[str, str], dict[str, str]]:
    """Grade ``submissions``; the grades.csv rows by (student, lab)."""
    grade_class(submissions, out, **kwargs)  # type: ignore[arg-type]
    return grade_rows(out)


def grade_rows(out: Path) -> dict[tuple[str, str], dict[str, str]]:
    """The rows of ``out``'s grades.csv by (student, lab)."""
    with open(out / "grades.csv") as f:
        return {(r["student_id"], r["assignment_id"]): r for r in csv.DictReader(f)}


def grade_lab(
    tmp_path_factory: pytest.TempPathFactory,
    round_trip: tuple[dict, Path],
    lab: str,
    submissions: dict[str, nbformat.NotebookNode],
    cell_timeout: int,
) -> tuple[dict, Path]:
    """``submissions`` of ``lab`` (notebooks by student) graded as a class, with the run's
    round trip rows ("right", "untouched") beside them (``with_round_trip``): those two
    students are the round trip's, never graded again here."""
    shared = ("right", "untouched")
    root = tmp_path_factory.mktemp("submissions")
    for student, notebook in submissions.items():
        if student not in shared:
            submit(root, student, lab, notebook)
    out = tmp_path_factory.mktemp("out")
    rows = grade(root, out, assignment_id=lab, workers=2, cell_timeout=cell_timeout)
    return with_round_trip((rows, out), round_trip, lab, shared)


def status_and_score(graded: tuple[dict, Path], lab: str, student: str) -> tuple[str, str]:
    """The status and score of ``student``'s row of ``lab`` in a graded class."""
    row = graded[0][(student, lab)]
    return row["status"], row["score"]


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


def live_marked_processes() -> list[int]:
    """Processes started by a grading job of this test process that are still alive
    (the grader reserves domains in this, the test, process)."""
    return marked_processes(os.getpid())


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


#: Replaces every check in the module ``_m`` (except building the node) by a mock
#: that accepts anything: the test cells then pass in the kernel whatever the code does.
NEUTER = """
from unittest import mock as _mock
for _name in list(vars(_m)):
    if not _name.startswith('_') and _name != 'make_node' and callable(getattr(_m, _name)):
        setattr(_m, _name, _mock.MagicMock())
"""

ATTACKS = {
    # The kernel runs every later cell, hidden tests included, as `pass`.
    "input_transformer": "get_ipython().input_transformers_post.append(lambda lines: ['pass\\n'])",
    # Test cells (they call checks.) become SystemExit, every other cell runs.
    "system_exit": (
        "get_ipython().input_transformers_post.append(\n"
        "    lambda lines: ['raise SystemExit(0)\\n'] if 'checks.' in ''.join(lines) else lines)"
    ),
    # Before every cell, the checks are replaced again.
    "pre_run_cell_hook": (
        "def _hook(info):\n    import rosbook.labs.lab01 as _m\n"
        + "\n".join("    " + ln for ln in NEUTER.strip().splitlines())
        + "\nget_ipython().events.register('pre_run_cell', _hook)"
    ),
    # Errors are neither shown nor reported: the cell looks like it passed.
    "post_run_cell_hook": (
        "ip = get_ipython()\nip.showtraceback = lambda *a, **k: None\n"
        "def _clear(result):\n    result.error_in_exec = None\n"
        "ip.events.register('post_run_cell', _clear)"
    ),
    # Cells that call the checks are run as `pass`.
    "run_cell_replaced": (
        "ip = get_ipython()\n_run, _run_async = ip.run_cell, ip.run_cell_async\n"
        "def _skip(cell):\n    return 'pass' if 'checks.' in cell else cell\n"
        "ip.run_cell = lambda raw_cell, *a, **k: _run(_skip(raw_cell), *a, **k)\n"
        "ip.run_cell_async = lambda raw_cell, *a, **k: _run_async(_skip(raw_cell), *a, **k)"
    ),
    "importlib": "import importlib\n_m = importlib.import_module('rosbook.labs.lab01')" + NEUTER,
    "alias": "import rosbook.labs.lab01 as _m" + NEUTER,
    "sys_modules": "import sys\n_m = sys.modules['rosbook.labs.lab01']" + NEUTER,
    "gc": (
        "import gc\n_m = next(o for o in gc.get_objects()\n"
        "          if type(o).__name__ == 'module' and o.__name__ == 'rosbook.labs.lab01')" + NEUTER
    ),
    "exec_base64": (
        "import base64\nexec(base64.b64decode("
        + repr(base64.b64encode(("import rosbook.labs.lab01 as _m" + NEUTER).encode()).decode())
        + "))"
    ),
    # `checks` is looked up in the builtins once the notebook's own name is gone.
    "builtins_override": (
        "import builtins, types\n_m = types.SimpleNamespace(**vars(checks))"
        + NEUTER
        + "builtins.checks = _m\ndel checks"
    ),
    # A test cell's output that says "pass", and no error output at all.
    "fake_pass_printed": (
        "ip = get_ipython()\nip.showtraceback = lambda *a, **k: print('PASS: all checks passed')"
    ),
}


#: Lab 1, whose right and wrong submissions several test files grade.
LAB01 = "lab01_nodes_topics"


def lab01_wrong() -> nbformat.NotebookNode:
    """Publisher on the wrong topic, doubler that triples, talker with the old Ctrl-C code."""
    fixes = {}
    fixes.update(replace_in_answer(LAB01, "counter_publisher", "'counter'", "'count'"))
    fixes.update(replace_in_answer(LAB01, "doubler", "2 * msg.data", "3 * msg.data"))
    talker = replace_in_answer(LAB01, "talker_script", "rclpy.try_shutdown()", "rclpy.shutdown()")
    talker["talker_script"] = talker["talker_script"].replace(
        "except (KeyboardInterrupt, ExternalShutdownException):", "except KeyboardInterrupt:"
    )
    fixes.update(talker)
    return answered(LAB01, **fixes)


#: Labs 2, 4 and 5, some of whose wrong submissions the attack tests grade too.
LAB02, LAB04, LAB05 = "lab02_qos", "lab04_urdf", "lab05_diff_drive"


def lab02_volatile_map_publisher() -> nbformat.NotebookNode:
    """Lab 2's map published VOLATILE: a late subscriber never gets it."""
    return answered(
        LAB02,
        **replace_in_answer(
            LAB02, "map_publisher", "DurabilityPolicy.TRANSIENT_LOCAL", "DurabilityPolicy.VOLATILE"
        ),
    )


def lab04_axis_wrong() -> nbformat.NotebookNode:
    """Wheel axes 0 0 1 (the robot rolls backwards), and an arm that counts q1 twice."""
    fixes = replace_in_answer(
        LAB04, "diff_drive_urdf", '<axis xyz="0 0 -1"/>', '<axis xyz="0 0 1"/>'
    )
    fixes.update(replace_in_answer(LAB04, "arm_fk", "rotation_z(q2)", "rotation_z(q1 + q2)"))
    return answered(LAB04, **fixes)


def lab05_swapped() -> nbformat.NotebookNode:
    """Lab 5's wheel speeds returned right, left: the robot turns the wrong way."""
    return answered(
        LAB05,
        **replace_in_answer(LAB05, "wheel_speeds", "return left, right", "return right, left"),
    )
