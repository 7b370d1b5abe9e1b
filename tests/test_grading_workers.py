"""A class grading run starts its worker processes before it generates the labs, so a
worker's seconds of importing nbgrader overlap the generation instead of adding to the
first submission's time; if generating fails, the started workers are stopped."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from autograder import grade
from tests.labtools import answered, submit

LAB = "lab01_nodes_topics"


def test_workers_start_before_the_labs_generate_and_stop_when_that_fails(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    submissions = tmp_path / "submitted"
    submit(submissions, "erin", LAB, answered(LAB))
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
