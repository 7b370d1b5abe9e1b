"""A class grading run starts its worker processes before it generates the labs, so a
worker's seconds of importing nbgrader overlap the generation instead of adding to the
first submission's time; if generating fails, the started workers are stopped."""

from __future__ import annotations

import subprocess
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
