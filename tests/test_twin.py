"""rosbook.viz.twin: the URDF robot in MeshCat follows the simulator, recorded or live."""

from __future__ import annotations

import base64
import math
import re
import time

import numpy as np
import pytest
import umsgpack
from geometry_msgs.msg import Twist
from rclpy.node import Node

from rosbook import robots
from rosbook.runtime.session import Session
from rosbook.sim.node import Simulation, yaw_of
from rosbook.sim.physics import DiffDriveSim, RobotGeometry, World
from rosbook.viz import scene as viz
from rosbook.viz import twin


@pytest.fixture(scope="module")
def bot():
    return robots.diff_drive()


def decoded(scene: viz.Scene) -> list[dict]:
    """The scene's commands as the viewer receives them (msgpack round trip)."""
    return [umsgpack.unpackb(packed) for packed in scene.packed]


def drive_arc() -> DiffDriveSim:
    """Straight, a left arc, a right turn on the spot, backwards: every sign of motion."""
    sim = DiffDriveSim(World(arena=(-3.0, -3.0, 3.0, 3.0)))
    for v, w, seconds in [(0.3, 0.0, 2.0), (0.25, 0.6, 3.0), (0.0, -1.0, 1.3), (-0.2, 0.0, 1.0)]:
        sim.command(v, w)
        sim.run(seconds)
    return sim


def test_the_packaged_urdf_has_the_simulators_dimensions(bot) -> None:
    geometry = RobotGeometry()
    left = bot.position("left_wheel")
    right = bot.position("right_wheel")
    assert left[1] - right[1] == pytest.approx(geometry.wheel_separation)
    wheel = bot.model.robot.links[bot.links.index("left_wheel")].visuals[0].geometry
    assert float(wheel.cylinder.radius) == pytest.approx(geometry.wheel_radius)
    (box,) = bot.model.link_map["base_link"].visuals
    assert [float(v) for v in box.geometry.box.size[:2]] == [geometry.length, geometry.width]
    assert box.origin[0, 3] == pytest.approx(geometry.box_x), "the box behind the axle"
    assert robots.DIFF_DRIVE_URDF.is_file() and robots.DIFF_DRIVE_URDF.parent.name == "robots"


def test_the_urdfs_base_link_is_the_middle_of_the_wheel_axle(bot) -> None:
    """One base_link (REP 105): the URDF's is the simulator's and odometry's, the middle of
    the axle, so the wheel joints sit symmetric about its origin with no x or z offset."""
    left = bot.position("left_wheel")
    right = bot.position("right_wheel")
    np.testing.assert_allclose((left + right) / 2, [0.0, 0.0, 0.0], atol=1e-12)
    assert left[1] == pytest.approx(-right[1]) and left[1] > 0
    # it turns on the spot about that point: the twin's base_link follows the sim's pose
    sim = DiffDriveSim()
    sim.command(0.0, 1.0)
    sim.run(1.0)
    assert (sim.pose.x, sim.pose.y) == pytest.approx((0.0, 0.0), abs=1e-12)


def test_the_twin_puts_the_simulators_pose_on_base_link_with_no_offset(bot) -> None:
    sim = drive_arc()
    frame = twin.current_frame(sim)
    assert (frame.x, frame.y, frame.yaw) == (sim.pose.x, sim.pose.y, sim.pose.yaw)
    for recorded, sampled in zip(sim.twin_frames(0.5), sim.trajectory.sample(0.5).x):
        assert recorded.x == sampled
    poses = twin.final_poses(decoded(twin.record(sim, fps=15)), bot.name)
    base = poses["base_link"]
    assert (base[0, 3], base[1, 3]) == pytest.approx((sim.pose.x, sim.pose.y), abs=1e-9)
    assert math.atan2(base[1, 0], base[0, 0]) == pytest.approx(sim.pose.yaw, abs=1e-9)


def test_a_positive_wheel_angle_rolls_the_urdf_wheel_forwards(bot) -> None:
    """Driving 0.1 m forwards turns each wheel by +0.1 / r; in the URDF that angle turns
    the wheel's top forwards (and its bottom backwards): it rolls towards +x."""
    sim = DiffDriveSim()
    sim.command(0.1, 0.0)
    sim.run(1.0)
    frame = twin.current_frame(sim)
    r = sim.geometry.wheel_radius
    assert frame.left_wheel == pytest.approx(0.1 / r) == frame.right_wheel
    for joint in robots.WHEEL_JOINTS:
        link = bot.joint(joint).child
        still, turned = bot.pose(link), bot.poses(twin.joint_positions(frame))[link]
        top = still[:3, 3] + [0.0, 0.0, r]  # the rim point on top of the wheel, at rest
        in_wheel = np.linalg.inv(still) @ np.append(top, 1.0)
        moved = (turned @ in_wheel)[:3] - turned[:3, 3]
        a = 0.1 / r
        np.testing.assert_allclose(moved, [r * math.sin(a), 0.0, r * math.cos(a)], atol=1e-6)


def test_recorded_twin_ends_at_the_simulators_final_pose(bot) -> None:
    sim = drive_arc()
    scene = twin.record(sim, fps=15)
    poses = twin.final_poses(decoded(scene), bot.name)
    assert set(poses) == set(bot.links)
    end = twin.axle_pose(poses)
    pose = sim.pose
    assert (end.x, end.y) == pytest.approx((pose.x, pose.y), abs=1e-9)
    assert math.remainder(end.yaw - pose.yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    # and the wheels are turned by the simulator's final angles
    left, right = sim.wheel_angles
    for link, angle in (("left_wheel", left), ("right_wheel", right)):
        relative = np.linalg.inv(poses["base_link"]) @ poses[link]
        expected = bot.poses({robots.LEFT_WHEEL_JOINT: left, robots.RIGHT_WHEEL_JOINT: right})[link]
        np.testing.assert_allclose(relative, expected, atol=1e-9, err_msg=f"{link} at {angle}")


def test_recorded_twin_animates_every_frame_and_draws_the_world(bot) -> None:
    sim = drive_arc()
    commands = decoded(twin.record(sim, fps=10))
    (animation,) = [c for c in commands if c["type"] == "set_animation"]
    paths = {a["path"] for a in animation["animations"]}
    assert paths == {f"/meshcat/bot{p}" for p in ("", "/left_wheel", "/right_wheel")}
    assert animation["options"]["repetitions"] == 1000, "a recorded drive plays in a loop"
    base = next(a for a in animation["animations"] if a["path"] == "/meshcat/bot")
    keys = base["clip"]["tracks"][0]["keys"]
    assert len(keys) == int(sim.time * 10) + 1 and base["clip"]["fps"] == 10
    # the first frame: the start pose, base_link (the axle) a wheel radius above the floor
    assert keys[0]["value"] == pytest.approx([0.0, 0.0, 0.04])
    walls = [c for c in commands if c["type"] == "set_object" and "/meshcat/world/" in c["path"]]
    assert len(walls) == 4, "the arena's four walls"


def test_a_recorded_drive_stays_small_at_book_frame_rates() -> None:
    sim = DiffDriveSim()
    sim.command(0.25, 0.3)
    sim.run(26.0)
    scene = twin.record(sim)  # 15 frames per simulated second
    assert scene.nbytes() < 200_000, scene


def test_following_a_ros_simulation_ends_at_its_odom_pose(session: Session, bot) -> None:
    sim = Simulation(World())

    class Arc(Node):
        def __init__(self) -> None:
            super().__init__("arc")
            self.pub = self.create_publisher(Twist, "cmd_vel", 10)
            self.timer = self.create_timer(0.02, self.on_timer)

        def on_timer(self) -> None:
            cmd = Twist()
            cmd.linear.x, cmd.angular.z = 0.3, 0.8
            self.pub.publish(cmd)

    Arc()
    followed = twin.Twin()
    stopped = followed.follow(sim, 3.0, fps=20, realtime=False, until=lambda: sim.now >= 2.0)
    assert stopped and sim.now == pytest.approx(2.0)
    odom = sim.node.odometry()
    poses = twin.final_poses(followed.view.vis.window.commands, bot.name)
    end = twin.axle_pose(poses)
    position = odom.pose.pose.position
    assert (end.x, end.y) == pytest.approx((position.x, position.y), abs=1e-9)
    assert end.yaw == pytest.approx(yaw_of(odom), abs=1e-9)
    assert position.y > 0.3, "the robot should have driven a left arc"


def test_follow_moves_a_live_view_in_real_time_and_its_server_stops(bot) -> None:
    vis = viz.live_visualizer()
    proc = vis.window.server_proc
    try:
        live = twin.Twin(vis=vis, world=World())
        sim = DiffDriveSim()
        sim.command(0.4, 0.0)
        started = time.perf_counter()
        live.follow(sim, 0.5, fps=20)
        took = time.perf_counter() - started
        assert 0.45 < took < 3.0, f"0.5 simulated seconds took {took:.2f} s in real time"
        # What the server holds (and a browser opening the view gets): the robot where the
        # simulator is, in its world.
        served = [
            umsgpack.unpackb(base64.b64decode(blob))
            for blob in re.findall(r"octet-binary;base64,([^\"]+)", vis.static_html())
        ]
        end = twin.axle_pose(twin.final_poses(served, bot.name))
        assert (end.x, end.y, end.yaw) == pytest.approx((0.2, 0.0, 0.0), abs=1e-9)
        assert sim.pose.x == pytest.approx(0.2)
        assert any(c.get("path", "").startswith("/meshcat/world/wall") for c in served)
    finally:
        viz.close_live(vis)
    assert proc.poll() is not None, "the MeshCat server process is still running"


def test_a_run_replayed_from_its_last_seconds_is_framed_on_them(bot) -> None:
    """``last``: only the run's last seconds are animated, ending where it ended, and the
    view frames where the robot drove then, not the whole world (still drawn)."""
    sim = drive_arc()
    whole, tail = twin.record(sim, fps=10), twin.record(sim, fps=10, last=1.0)
    (animation,) = [c for c in decoded(tail) if c["type"] == "set_animation"]
    base = next(a for a in animation["animations"] if a["path"] == "/meshcat/bot")
    keys = base["clip"]["tracks"][0]["keys"]
    assert len(keys) == 11  # 1 s at 10 frames a second, both ends
    end = twin.axle_pose(twin.final_poses(decoded(tail), bot.name))
    assert (end.x, end.y) == pytest.approx((sim.pose.x, sim.pose.y), abs=1e-9)
    walls = [c for c in decoded(tail) if c["type"] == "set_object" and "/world/" in c["path"]]
    assert len(walls) == 4, "the world is drawn all the same"
    assert tail.frame["radius"] < whole.frame["radius"]
    # framed on the last second alone: not on where the robot stood when the twin was made
    # (the origin, far from the run's end here)
    last_second = [f for f in sim.twin_frames(0.1) if f.t >= sim.time - 1.0 - 1e-9]
    middle = np.mean([(f.x, f.y) for f in last_second], axis=0)
    assert math.dist(tail.frame["target"][:2], middle) < 0.3, (tail.frame, middle)
