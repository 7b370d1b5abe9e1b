"""How fast the ``ros2`` verbs answer, each started cold as a user types it.

With ``rosbook.demos.nodes`` running in another process (two nodes, a service, an
action, parameters), in a domain of its own, measured in the same run:

- "python + rclpy start (median)": ``python -c`` that imports rclpy, initialises and
  shuts down: the floor under every cold command;
- "node list, no daemon (median)": ``ros2 node list --no-daemon``, the direct path: a
  new node that waits until its discovery has settled;
- then with the graph daemon running (``ros2 daemon start``; ``rosbook.cli.daemon``),
  each command still a new process, as a user types it:
- "node list, cold (median)": ``ros2 node list`` until it prints; target 0.7 s on 2 cores;
- "absent topic answer (median)": ``ros2 topic info /absent``, the graph settled (the
  demo nodes up); target 1.5 s;
- "present topic answer (median)": ``ros2 topic info /parameter_events``.
"""

from __future__ import annotations

import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path

from benchmarks import Figure, sized
from rosbook.runtime.isolation import isolated_environ

RUNS = sized(7, 1)
ROS2 = [str(Path(sys.executable).with_name("ros2"))]
RCLPY_START = [
    sys.executable,
    "-c",
    "import rclpy; rclpy.init(); rclpy.shutdown()",
]


def seconds(command: list[str], expect_code: int) -> float:
    """Wall time of one run of ``command``; it must exit with ``expect_code``."""
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
    elapsed = time.perf_counter() - start
    if done.returncode != expect_code:
        raise RuntimeError(
            f"{' '.join(command)} exited {done.returncode}, expected {expect_code}: "
            f"{done.stdout}{done.stderr}"
        )
    return elapsed


def median(command: list[str], expect_code: int = 0, runs: int = RUNS) -> float:
    return statistics.median(seconds(command, expect_code) for _ in range(runs))


def wait_for_demo_nodes(limit: float = 120.0) -> None:
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline:
        listed = subprocess.run([*ROS2, "node", "list"], capture_output=True, text=True)
        if "/clock_server" in listed.stdout and "/countdown_server" in listed.stdout:
            return
    raise RuntimeError(f"rosbook.demos.nodes not on the graph after {limit:g} s")


def run() -> list[Figure]:
    with isolated_environ():
        demo = subprocess.Popen(
            [sys.executable, "-m", "rosbook.demos.nodes"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        try:
            wait_for_demo_nodes()
            start = median(RCLPY_START)
            direct = median([*ROS2, "node", "list", "--no-daemon"])
            seconds([*ROS2, "daemon", "start"], expect_code=0)
            listing = median([*ROS2, "node", "list"])
            absent = median([*ROS2, "topic", "info", "/absent"], expect_code=1)
            present = median([*ROS2, "topic", "info", "/parameter_events"])
        finally:
            subprocess.run([*ROS2, "daemon", "stop"], capture_output=True, timeout=120)
            demo.send_signal(signal.SIGINT)
            try:
                demo.wait(timeout=30)
            except subprocess.TimeoutExpired:
                demo.kill()
                demo.wait()
    return [
        Figure("python + rclpy start (median)", start, "s"),
        Figure("node list, no daemon (median)", direct, "s"),
        Figure("node list, cold (median; target 0.7)", listing, "s"),
        Figure("absent topic answer (median; target 1.5)", absent, "s"),
        Figure("present topic answer (median)", present, "s"),
    ]
