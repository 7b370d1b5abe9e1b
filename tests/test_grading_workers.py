"""A class grading run starts its worker processes before it generates the labs, so a
worker's seconds of importing nbgrader overlap the generation instead of adding to the
first submission's time; if generating fails, the started workers are stopped."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import nbformat
import pytest
from nbgrader.dbutil import ALEMBIC_DIR

from autograder import grade, kernels
from tests.labtools import answered, notebook_path, submit

LAB = "lab01_nodes_topics"


def test_workers_start_before_the_labs_generate_and_stop_when_that_fails(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    submissions = tmp_path / "submitted"
    for student in ("erin", "frank"):  # two to grade: two workers start
        submit(submissions, student, LAB, answered(LAB))
    started: list[subprocess.Popen[bytes]] = []
    real_start = grade.WorkerSlot.start

    def start(slot: grade.WorkerSlot) -> None:
        real_start(slot)
        assert slot.proc is not None
        started.append(slot.proc)

    def failing_prepare(*args: Any, **kwargs: Any) -> grade.Assignment:
        running = [p for p in started if p.poll() is None]
        raise RuntimeError(f"{len(running)} worker(s) running while generating")

    monkeypatch.setattr(grade.WorkerSlot, "start", start)
    monkeypatch.setattr(grade, "prepare", failing_prepare)
    with pytest.raises(RuntimeError, match="^2 worker"):
        grade.grade_class(submissions, tmp_path / "out", assignment_id=LAB, workers=2)
    for proc in started:  # stopped (killed), not left to import and wait for jobs
        assert proc.wait(timeout=30) is not None, "timeout: a worker was left running"


def test_a_grading_worker_starts_without_compiling_jsonschemas_iri_grammar() -> None:
    # rfc3987_syntax compiles a Lark grammar at import (1.2 s); nbformat validates as before
    code = (
        "import sys, autograder.worker, nbformat; "
        "nbformat.validate(nbformat.read(sys.argv[1], as_version=4)); "
        "print(sorted(m for m in sys.modules if m.startswith(('rfc3987_syntax', 'lark'))))"
    )
    notebook = Path(__file__).resolve().parent.parent / "solutions" / LAB / f"{LAB}.ipynb"
    run = subprocess.run(
        [sys.executable, "-c", code, str(notebook)], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.strip() == "['rfc3987_syntax']"  # the None that stands in for it


def test_a_new_gradebook_is_stamped_with_nbgraders_schema_head_without_a_command(
    tmp_path: Path,
) -> None:
    """nbgrader asks the `alembic heads` command (a Python start importing nbgrader
    again: 0.4-5.5 s) for the revision of each gradebook it creates; the grader reads
    it in its own process. With no command reachable the gradebook is still made, with
    the revision the command gives."""
    (tmp_path / "alembic.ini").write_text(f"[alembic]\nscript_location = {ALEMBIC_DIR}\n")
    heads = subprocess.run(
        [str(Path(sys.executable).parent / "alembic"), "-c", "alembic.ini", "heads"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert heads.returncode == 0, heads.stderr[-2000:]
    code = (
        "import os, sqlite3, sys, autograder.course; from nbgrader.api import Gradebook; "
        "os.environ['PATH'] = ''; "
        "Gradebook('sqlite:///' + sys.argv[1]).close(); "
        "print(sqlite3.connect(sys.argv[1]).execute('select * from alembic_version').fetchall())"
    )
    made = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path / "gradebook.db")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert made.returncode == 0, made.stderr[-2000:]
    assert made.stdout.strip() == repr([(heads.stdout.split()[0],)])


#: A cell each test student adds after the set-up: what its kernel sees.
SEEN = """import os
print("cwd", os.path.basename(os.getcwd()), sorted(os.listdir(".")))
try:
    import helper
    print("helper", helper.WHO)
except ModuleNotFoundError:
    print("helper missing")
"""


@pytest.mark.slow
def test_each_submission_runs_in_a_fresh_kernel_that_sees_only_its_own_files(
    tmp_path: Path,
) -> None:
    """With one worker, the second and third submissions run in kernels started ahead
    (at the end of the one before): each sees its own folder as a kernel started for it
    does (its files there, its module importable), nothing of the one before."""
    notebook = nbformat.read(notebook_path(LAB), as_version=4)  # unanswered: fails fast
    notebook.cells.insert(2, nbformat.v4.new_code_cell(SEEN))
    submissions = tmp_path / "submitted"
    for student, helper in (("ann", "ann"), ("bob", "bob"), ("cid", None)):
        submit(submissions, student, LAB, notebook)
        if helper:
            (submissions / student / LAB / "helper.py").write_text(f"WHO = {helper!r}\n")
    out = tmp_path / "out"
    rows = grade.grade_class(submissions, out, assignment_id=LAB, workers=1)
    assert [r.status for r in rows] == ["ok"] * 3, [r.message for r in rows]
    seen = {}
    for student in ("ann", "bob", "cid"):
        graded = nbformat.read(out / "autograded" / student / LAB / f"{LAB}.ipynb", as_version=4)
        seen[student] = "".join(o.get("text", "") for o in graded.cells[2].outputs)
    assert seen["ann"] == "cwd lab01_nodes_topics ['helper.py']\nhelper ann\n", seen
    assert seen["bob"] == "cwd lab01_nodes_topics ['helper.py']\nhelper bob\n", seen
    assert seen["cid"] == "cwd lab01_nodes_topics []\nhelper missing\n", seen
    ahead = {
        student: kernels.STARTED_AHEAD in (out / "logs" / student / f"{LAB}.log").read_text()
        for student in ("ann", "bob", "cid")
    }
    assert ahead == {"ann": False, "bob": True, "cid": True}
