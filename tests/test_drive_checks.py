"""Lab 5's driving checks: a run ends when its verdict is known, and is the same every time."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node

from rosbook.labs import lab05 as drive_checks
from rosbook.runtime.session import ros
from rosbook.sim.node import yaw_of
from rosbook.sim.physics import World


class ToPoint(Node):
    """Drives to (1, 0.5) with odom feedback and stops: a closed loop, like the lab's."""

    def __init__(self, node_name: str = "to_point", speed: float = 0.3) -> None:
        super().__init__(node_name)
        self.speed = speed
        self.pose: tuple[float, float, float] | None = None
        self.cmd_pub = self.create_publisher(Twist, "cmd_vel", 10)
        self.create_subscription(Odometry, "odom", self.on_odom, 10)
        self.create_timer(0.02, self.on_timer)

    def on_odom(self, msg: Odometry) -> None:
        p = msg.pose.pose.position
        self.pose = (p.x, p.y, yaw_of(msg))

    def on_timer(self) -> None:
        cmd = Twist()
        if self.pose is not None:
            x, y, yaw = self.pose
            dx, dy = 1.0 - x, 0.5 - y
            if math.hypot(dx, dy) > 0.02:
                error = math.remainder(math.atan2(dy, dx) - yaw, 2 * math.pi)
                cmd.angular.z = max(-1.0, min(1.0, 2.0 * error))
                cmd.linear.x = self.speed * max(0.0, math.cos(error))
        self.cmd_pub.publish(cmd)


@pytest.fixture(autouse=True)
def reset_session() -> Iterator[None]:
    yield
    ros.reset()


def test_a_run_ends_once_the_robot_stood_still_at_its_target() -> None:
    finish = drive_checks.Finish((1.0, 0.5), tolerance=0.05, still=1.0)
    run = drive_checks.drive(ToPoint, world=World(arena=None), seconds=30.0, finish=finish)
    assert run.seconds < 10.0, "the verdict was known long before 30 s"
    drive_checks.assert_goal(run, (1.0, 0.5))
    drive_checks.assert_stopped(run, last=1.0)


def test_a_run_ends_at_the_first_collision() -> None:
    world = World(arena=(-1.0, -1.0, 0.8, 1.0))  # the wall at x = 0.8 is in the way
    finish = drive_checks.Finish((1.0, 0.5), tolerance=0.05, still=1.0)
    run = drive_checks.drive(ToPoint, world=world, seconds=30.0, finish=finish)
    hits = run.sim.physics.collisions
    assert hits and run.seconds - hits[0].t <= 0.02 + 1e-9
    with pytest.raises(AssertionError, match="slow down and stop in time"):
        drive_checks.assert_no_collision(run, (1.0, 0.5))


def test_without_a_finish_the_run_takes_all_its_seconds() -> None:
    run = drive_checks.drive(ToPoint, world=World(arena=None), seconds=12.0)
    assert run.seconds == pytest.approx(12.0)


def test_a_closed_loop_run_is_the_same_to_the_bit_every_time() -> None:
    def path() -> bytes:
        run = drive_checks.drive(ToPoint, world=World(arena=None), seconds=6.0)
        return run.path.tobytes()

    assert path() == path()


def test_a_wrong_final_heading_is_named() -> None:
    run = drive_checks.drive(
        ToPoint,
        world=World(arena=None),
        seconds=30.0,
        finish=drive_checks.Finish((1.0, 0.5), tolerance=0.05, still=1.0),
    )
    with pytest.raises(AssertionError, match="Is the final turn missing"):
        drive_checks.assert_heading(run, math.pi)
