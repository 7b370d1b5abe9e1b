"""Lab 1 grading speed: per submission, and against plain sequential nbgrader.

Twenty correct submissions are graded twice in the same run: by ``python -m autograder
grade --workers 2`` (isolated, parallel, with feedback) and by one plain ``nbgrader
autograde`` of all twenty (sequential, no feedback). Target: ratio at most 0.6.

The sandbox's cost is measured on its own, in the same run: a kernel started, made to
create a ROS node, and shut down, sandboxed (``IpcKernelManager``) and plain
(jupyter_client's ``AsyncKernelManager`` on Unix sockets too, as the book's kernels:
``AsyncUnixSocketKernelManager``), median of three each. Target: ratio <= 1.2.
"""

from __future__ import annotations

import asyncio
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from jupyter_client import AsyncKernelManager

from autograder.config import PACKAGE_DIR, SOLUTIONS
from autograder.grade import grade_class
from autograder.kernels import IpcKernelManager
from benchmarks import Figure, sized
from rosbook.runtime.isolation import run_isolated
from rosbook.runtime.kernels import AsyncUnixSocketKernelManager
from tests.labtools import answered, submit

LAB = "lab01_nodes_topics"
STUDENTS = [f"student_{i:02d}" for i in range(sized(20, 2))]


def plain_nbgrader_seconds(submissions: Path, work: Path) -> float:
    """Sequential ``nbgrader autograde`` of every student, in one isolated domain."""
    course = work / "course"
    shutil.copytree(SOLUTIONS / LAB, course / "solutions" / LAB)
    shutil.copytree(submissions, course / "submitted")
    shutil.copy(PACKAGE_DIR / "nbgrader_config.py", course)  # read from the working folder
    nbgrader = [sys.executable, "-m", "nbgrader"]
    common = ["--log-level=ERROR"]
    subprocess.run(
        [*nbgrader, "generate_assignment", LAB, "--force", *common], check=True, cwd=course
    )
    start = time.monotonic()
    code = run_isolated([*nbgrader, "autograde", LAB, "--create", "--force", *common], cwd=course)
    elapsed = time.monotonic() - start
    if code != 0:
        raise RuntimeError(f"nbgrader autograde failed with exit code {code}")
    return elapsed


KERNEL_WORK = (
    "import rclpy\nrclpy.init()\nrclpy.create_node('bench').destroy_node()\nrclpy.shutdown()"
)


async def kernel_round_trip(manager: AsyncKernelManager, folder: Path) -> float:
    """Seconds to start ``manager``'s kernel in ``folder``, run ``KERNEL_WORK``, stop it."""
    start = time.monotonic()
    await manager.start_kernel(cwd=str(folder))
    client = manager.client()
    client.start_channels()
    try:
        await client.wait_for_ready(timeout=300)
        reply = await client.execute_interactive(KERNEL_WORK, timeout=300)
        if reply["content"]["status"] != "ok":
            raise RuntimeError(f"the benchmark kernel failed: {reply['content']}")
    finally:
        client.stop_channels()
        await manager.shutdown_kernel()
    return time.monotonic() - start


def kernel_seconds(folder: Path) -> tuple[float, float]:
    """Median round trips (sandboxed, plain), interleaved so both see the same load."""
    sandboxed, plain = [], []
    for _ in range(sized(3, 1)):
        sandboxed.append(asyncio.run(kernel_round_trip(IpcKernelManager(), folder)))
        plain.append(asyncio.run(kernel_round_trip(AsyncUnixSocketKernelManager(), folder)))
    return statistics.median(sandboxed), statistics.median(plain)


def run() -> list[Figure]:
    with tempfile.TemporaryDirectory(prefix="bench-lab01-") as tmp:
        work = Path(tmp)
        submissions = work / "submissions"
        notebook = answered(LAB)
        for student in STUDENTS:
            submit(submissions, student, LAB, notebook)
        start = time.monotonic()
        rows = grade_class(submissions, work / "out", assignment_id=LAB, workers=2)
        ours = time.monotonic() - start
        bad = [r for r in rows if r.status != "ok" or r.score != r.max_score]
        if bad:
            raise RuntimeError(f"benchmark submissions did not all score full marks: {bad}")
        baseline = plain_nbgrader_seconds(submissions, work)
        folder = work / "kernel"
        folder.mkdir()
        sandboxed, plain = kernel_seconds(folder)
    return [
        Figure("kernel start + ROS node + stop, sandboxed", sandboxed, "s"),
        Figure("kernel start + ROS node + stop, plain", plain, "s"),
        Figure("kernel sandboxed vs plain", sandboxed / plain, "ratio"),
        Figure("lab01 seconds per submission", statistics.median(r.seconds for r in rows), "s"),
        Figure(f"lab01 grading {len(STUDENTS)} submissions, --workers 2", ours, "s"),
        Figure(f"lab01 sequential nbgrader autograde of {len(STUDENTS)}", baseline, "s"),
        Figure("lab01 grading vs sequential nbgrader", ours / baseline, "ratio"),
    ]
