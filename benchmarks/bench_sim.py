"""The simulator's speed with ROS in the loop, and the time to grade one lab 5 submission.

Targets (issue 6): ``simulator real-time factor`` at least 20x on this machine, headless,
with the ROS node and a student-style controller in the loop at a 50 Hz control rate.
"""

from __future__ import annotations

import math
import statistics
import tempfile
import time
from pathlib import Path

from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import LaserScan

from benchmarks import Figure
from rosbook.isolation import isolated_environ
from rosbook.session import ros
from rosbook.sim import DiffDriveSim, World
from rosbook.sim_node import Simulation, yaw_of

SIM_SECONDS = 20.0


class Wanderer(Node):
    """A student-style 50 Hz controller: odom and scan in, cmd_vel out, turns away from walls."""

    def __init__(self) -> None:
        super().__init__("wanderer")
        self.pose: tuple[float, float, float] | None = None
        self.ahead = math.inf
        self.cmd_pub = self.create_publisher(Twist, "cmd_vel", 10)
        self.create_subscription(Odometry, "odom", self.on_odom, 10)
        self.create_subscription(LaserScan, "scan", self.on_scan, 10)
        self.timer = self.create_timer(0.02, self.on_timer)

    def on_odom(self, msg: Odometry) -> None:
        p = msg.pose.pose.position
        self.pose = (p.x, p.y, yaw_of(msg))

    def on_scan(self, msg: LaserScan) -> None:
        middle = len(msg.ranges) // 2
        self.ahead = min(msg.ranges[middle - 15 : middle + 15])

    def on_timer(self) -> None:
        cmd = Twist()
        if self.pose is not None:
            cmd.linear.x = 0.3 if self.ahead > 0.6 else 0.0
            cmd.angular.z = 0.2 if self.ahead > 0.6 else 1.0
        self.cmd_pub.publish(cmd)


def real_time_factor() -> tuple[float, float]:
    """Median over three runs of SIM_SECONDS with the wanderer in the loop: wall, CPU.

    The CPU-time factor is what the machine could do alone; the wall-clock factor is
    what it did while shared (the grading machine's two cores usually are).
    """
    wall, cpu = [], []
    for _ in range(3):
        sim = Simulation(World())
        Wanderer()
        started, started_cpu = time.perf_counter(), time.process_time()
        sim.run(SIM_SECONDS)
        wall.append(SIM_SECONDS / (time.perf_counter() - started))
        cpu.append(SIM_SECONDS / (time.process_time() - started_cpu))
    ros.reset()
    return statistics.median(wall), statistics.median(cpu)


def physics_steps_per_second() -> float:
    sim = DiffDriveSim(World())
    sim.command(0.3, 0.2)
    started = time.perf_counter()
    sim.step(20_000)
    return 20_000 / (time.perf_counter() - started)


def grade_one_submission() -> float:
    from autograder.grade import grade_class
    from tests.labtools import answered, submit

    lab = "lab05_diff_drive"
    with tempfile.TemporaryDirectory(prefix="bench-lab05-") as tmp:
        root = Path(tmp) / "submissions"
        submit(root, "student", lab, answered(lab))
        started = time.perf_counter()
        rows = grade_class(root, Path(tmp) / "out", assignment_id=lab, workers=1)
        elapsed = time.perf_counter() - started
    if rows[0].score != rows[0].max_score:
        raise RuntimeError(f"the solution did not score full marks: {rows[0]}")
    return elapsed


def run() -> list[Figure]:
    with isolated_environ():
        factor, cpu_factor = real_time_factor()
        ros.shutdown()
    return [
        Figure("simulator real-time factor", factor, "x"),
        Figure("simulator real-time factor per CPU second", cpu_factor, "x"),
        Figure("simulator physics steps per second", physics_steps_per_second(), "steps/s"),
        Figure("lab05 seconds per submission", grade_one_submission(), "s"),
    ]
