"""Service round trip between two processes, and the grading time of a lab 3 submission.

- "service round trip": median wall time of one ``std_srvs/srv/Trigger`` call from
  this process to ``rosbook.demos.nodes`` in another (request out, response in), with
  a client made once, over real DDS on localhost. A few milliseconds is the target.
- "lab03 seconds per submission": wall time of ``autograder`` grading lab 3's solution
  notebook (kernel start, every cell, feedback), one worker, divided by the number of
  submissions.
"""

from __future__ import annotations

import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import nbformat
from rclpy.node import Node
from std_srvs.srv import Trigger

from autograder.config import LABS, SOLUTIONS
from autograder.grade import grade_class
from benchmarks import Figure, sized
from rosbook.runtime.isolation import isolated_environ
from rosbook.runtime.session import ros

CALLS = sized(200, 20)
SUBMISSIONS = sized(2, 1)
LAB = "lab03_services_actions"


def round_trip_ms(calls: int = CALLS) -> float:
    """Median milliseconds per Trigger call to a server in another process."""
    server = subprocess.Popen(
        [sys.executable, "-m", "rosbook.demos.nodes"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        ros.init()
        node = Node("bench_client")
        client = node.create_client(Trigger, "what_time")
        if not client.wait_for_service(timeout_sec=15.0):
            raise RuntimeError("rosbook.demos.nodes did not start serving what_time")
        times = []
        for _ in range(calls + 10):
            start = time.perf_counter()
            future = client.call_async(Trigger.Request())
            if not ros.spin_until(future.done, node, timeout=2.0):
                raise RuntimeError("what_time did not answer within 2 s")
            times.append(time.perf_counter() - start)
        return 1000 * statistics.median(times[10:])  # the first calls warm up
    finally:
        ros.shutdown()
        server.send_signal(signal.SIGINT)
        try:
            server.wait(timeout=10)
        except subprocess.TimeoutExpired:
            server.kill()


def answered_release() -> nbformat.NotebookNode:
    """The released lab with every answer cell filled in as in the solution."""
    solution = nbformat.read(SOLUTIONS / LAB / f"{LAB}.ipynb", as_version=4)
    answers = {
        c.metadata.nbgrader["grade_id"]: "\n".join(
            line
            for line in c.source.splitlines()
            if line.strip() not in ("### BEGIN SOLUTION", "### END SOLUTION")
        )
        for c in solution.cells
        if c.metadata.get("nbgrader", {}).get("solution")
    }
    notebook = nbformat.read(LABS / LAB / f"{LAB}.ipynb", as_version=4)
    for cell in notebook.cells:
        grade_id = cell.metadata.get("nbgrader", {}).get("grade_id")
        if grade_id in answers and cell.metadata.nbgrader.get("solution"):
            cell.source = answers[grade_id]
    return notebook


def lab_seconds_per_submission(count: int = SUBMISSIONS) -> float:
    """Wall seconds to grade one answered lab 3 submission, one worker."""
    notebook = answered_release()
    with tempfile.TemporaryDirectory(prefix="bench-lab03-") as tmp:
        root = Path(tmp) / "submissions"
        for k in range(count):
            folder = root / f"student{k}" / LAB
            folder.mkdir(parents=True)
            nbformat.write(notebook, folder / f"{LAB}.ipynb")
        start = time.perf_counter()
        rows = grade_class(root, Path(tmp) / "out", assignment_id=LAB, workers=1)
        seconds = time.perf_counter() - start
    if any(r.status != "ok" or r.score != r.max_score for r in rows):
        raise RuntimeError(f"the solution did not grade at full marks: {rows}")
    return seconds / count


def run() -> list[Figure]:
    with isolated_environ():
        median_ms = round_trip_ms()
    return [
        Figure("service round trip (median, two processes)", median_ms, "ms"),
        Figure("lab03 seconds per submission", lab_seconds_per_submission(), "s"),
    ]
