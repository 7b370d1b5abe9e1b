"""The Pymunk simulator and its ROS node, checked against the closed form."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from sensor_msgs.msg import LaserScan
from std_srvs.srv import Trigger

from rosbook.runtime.callbacks import WakingExecutor
from rosbook.runtime.session import ros
from rosbook.sim.diff_drive import arc_step, wrap_angle
from rosbook.sim.node import Simulation, yaw_of
from rosbook.sim.physics import Box, DiffDriveSim, RobotGeometry, Wall, World

OPEN = World(arena=None)


def test_constant_twist_drives_a_circle_of_radius_v_over_w() -> None:
    sim = DiffDriveSim(OPEN)
    v, w = 0.3, 0.6
    sim.command(v, w)
    sim.run(8.0)
    traj = sim.trajectory
    distances = np.hypot(np.array(traj.x), np.array(traj.y) - v / w)
    assert np.max(np.abs(distances - v / w)) < 1e-9
    x, y, yaw = arc_step(0.0, 0.0, 0.0, v, w, 8.0)
    assert (sim.pose.x, sim.pose.y) == pytest.approx((x, y), abs=1e-9)
    assert sim.pose.yaw == pytest.approx(wrap_angle(yaw), abs=1e-9)
    assert sim.collisions == []


def test_zero_turn_rate_drives_a_straight_line() -> None:
    sim = DiffDriveSim(World(arena=None, start=(1.0, -1.0, math.pi / 4)))
    sim.command(0.4, 0.0)
    sim.run(5.0)
    d = 0.4 * 5.0
    assert (sim.pose.x, sim.pose.y) == pytest.approx((1 + d / math.sqrt(2), -1 + d / math.sqrt(2)))
    assert sim.pose.yaw == pytest.approx(math.pi / 4)


def test_turning_in_place_keeps_the_axle_middle_still() -> None:
    sim = DiffDriveSim(OPEN)
    sim.command(0.0, 1.0)
    sim.run(2.0)
    assert (sim.pose.x, sim.pose.y) == pytest.approx((0.0, 0.0), abs=1e-12)
    assert sim.pose.yaw == pytest.approx(2.0)
    left, right = sim.wheel_angles
    assert (left, right) == pytest.approx((-10.0, 10.0))  # w L / 2 / r = 5 rad/s for 2 s


def test_wheel_angles_follow_the_wheel_speeds() -> None:
    sim = DiffDriveSim(OPEN)
    sim.command_wheels(4.0, 6.0)
    sim.run(1.5)
    assert sim.wheel_angles == pytest.approx((6.0, 9.0))
    assert sim.twist == pytest.approx((0.04 * 5.0, 0.04 * 2.0 / 0.4))


def test_motor_limit_scales_both_wheels_and_keeps_the_curvature() -> None:
    sim = DiffDriveSim(OPEN, RobotGeometry(max_wheel_speed=10.0))
    sim.command(1.0, 2.0)  # wants (15, 35) rad/s
    assert sim.wheel_command == pytest.approx((15 * 10 / 35, 10.0))
    sim.run(1.0)
    v, w = sim.twist
    assert v / w == pytest.approx(0.5)


def noisy_path(seed: int) -> np.ndarray:
    sim = DiffDriveSim(World(boxes=(Box((1.5, 0.3), (0.4, 0.4)),)), seed=seed, wheel_noise=0.05)
    for v, w in [(0.3, 0.0), (0.2, 0.8), (0.5, -0.3), (0.4, 0.0)]:
        sim.command(v, w)
        sim.run(2.5)
    return sim.trajectory.as_array()


def test_same_seed_gives_the_same_path_to_the_bit() -> None:
    first, second = noisy_path(7), noisy_path(7)
    assert first.tobytes() == second.tobytes()
    assert not np.array_equal(first, noisy_path(8))


def test_driving_into_a_wall_is_reported_and_the_wall_holds() -> None:
    sim = DiffDriveSim(World(arena=(-2.0, -2.0, 2.0, 2.0)))
    sim.command(0.5, 0.0)
    sim.run(3.0)
    assert sim.collisions == [] and not sim.in_contact
    sim.run(3.0)
    assert len(sim.collisions) == 1, "pushing against the wall is one collision"
    first = sim.collisions[0]
    # the front of the base (0.1 m ahead of the axle) reaches x = 2 after 1.9 m
    assert first.t == pytest.approx(3.8, abs=0.01)
    assert first.x == pytest.approx(2.0, abs=0.01)
    front = max(x for x, _ in sim.geometry.footprint())
    assert sim.pose.x + front == pytest.approx(2.0, abs=0.0026)
    assert sim.pose.y == 0.0 and sim.pose.yaw == 0.0
    assert sim.in_contact and sim.twist == (0.0, 0.0)
    sim.command(-0.5, 0.0)  # backing away is free again
    sim.run(1.0)
    assert sim.pose.x == pytest.approx(1.4, abs=0.01) and not sim.in_contact


def test_scan_sees_the_walls_at_their_distances() -> None:
    sim = DiffDriveSim(World(arena=(-2.0, -1.5, 3.0, 2.5)))
    ranges = sim.scan()
    angles = sim.laser.angles()
    for angle, distance in [(0.0, 3.0), (math.pi / 2, 2.5), (-math.pi / 2, 1.5), (-math.pi, 2.0)]:
        i = int(np.argmin(np.abs(angles - angle)))
        assert ranges[i] == pytest.approx(distance, abs=1e-6)
    i = int(np.argmin(np.abs(angles - math.pi / 4)))  # towards the corner (2.5, 2.5)
    assert ranges[i] == pytest.approx(2.5 * math.sqrt(2), abs=1e-6)


def test_scan_turns_with_the_robot_and_sees_obstacles() -> None:
    world = World(arena=(-4.0, -4.0, 4.0, 4.0), boxes=(Box((0.0, 1.5), (0.4, 0.2)),))
    sim = DiffDriveSim(World(world.arena, (), world.boxes, start=(0.0, 0.0, math.pi / 2)))
    ranges = sim.scan()
    ahead = int(np.argmin(np.abs(sim.laser.angles())))
    assert ranges[ahead] == pytest.approx(1.4, abs=1e-6)
    assert np.isinf(DiffDriveSim(World(arena=None)).scan()).all()


def test_scan_agrees_with_pymunk_ray_queries() -> None:
    world = World(
        boxes=(Box((1.0, 0.5), (0.4, 0.3), 0.3), Box((-1.2, -1.0), (0.5, 0.5))),
        walls=(Wall((-1.0, -2.0), (-1.0, 1.0)),),
    )
    sim = DiffDriveSim(world)
    sim.command(0.2, 0.3)
    for _ in range(4):
        sim.run(1.5)
        ranges = sim.scan()
        rays = [sim.ray(a) for a in sim.laser.angles()]
        assert np.allclose(ranges, rays, atol=1e-9)


def test_world_from_a_dict() -> None:
    world = World.from_dict(
        {
            "arena": [-1, -1, 1, 1],
            "walls": [{"start": [0, -1], "end": [0, 0.5]}],
            "boxes": [{"center": [0.5, 0.5], "size": [0.2, 0.2]}],
            "start": [-0.3, 0, 0],
        }
    )
    assert world.arena == (-1, -1, 1, 1) and len(world.all_walls()) == 5
    sim = DiffDriveSim(world)
    assert sim.pose.x == -0.3
    ahead = int(np.argmin(np.abs(sim.laser.angles())))
    assert sim.scan()[ahead] == pytest.approx(0.3 - 0.025, abs=1e-6)


# -- on ROS topics -------------------------------------------------------------------


class ConstantDriver(Node):
    """A 50 Hz controller: publishes (v, w) on cmd_vel until `stop_at`, keeps every odom."""

    def __init__(self, v: float, w: float, stop_at: float = math.inf) -> None:
        super().__init__("constant_driver")
        self.v, self.w, self.stop_at = v, w, stop_at
        self.odom: list[Odometry] = []
        self.scans: list[LaserScan] = []
        self.ticks: list[float] = []
        self.pub = self.create_publisher(Twist, "cmd_vel", 10)
        self.create_subscription(Odometry, "odom", self.odom.append, 10)
        self.create_subscription(LaserScan, "scan", self.scans.append, 10)
        self.timer = self.create_timer(0.02, self.on_timer)

    def on_timer(self) -> None:
        now = self.get_clock().now().nanoseconds / 1e9
        self.ticks.append(now)
        if now <= self.stop_at + 1e-9:
            msg = Twist()
            msg.linear.x, msg.angular.z = self.v, self.w
            self.pub.publish(msg)


@pytest.fixture
def reset_session() -> Iterator[None]:
    yield
    ros.reset()


@pytest.mark.usefixtures("reset_session")
def test_cmd_vel_drives_the_circle_and_odom_reports_it() -> None:
    sim = Simulation(World(arena=None))
    driver = ConstantDriver(0.3, 0.6)
    sim.run(5.0)
    assert driver.ticks == pytest.approx([0.02 * (k + 1) for k in range(250)])
    last = driver.odom[-1]
    assert last.header.stamp.sec == 5 and last.header.stamp.nanosec == 0
    # the first command comes from the first timer tick, at t = 0.02 s
    x, y, yaw = arc_step(0.0, 0.0, 0.0, 0.3, 0.6, 5.0 - 0.02)
    p = last.pose.pose.position
    assert (p.x, p.y) == pytest.approx((x, y), abs=1e-9)
    assert yaw_of(last) == pytest.approx(wrap_angle(yaw), abs=1e-9)
    assert (last.twist.twist.linear.x, last.twist.twist.angular.z) == pytest.approx((0.3, 0.6))
    assert (last.header.frame_id, last.child_frame_id) == ("odom", "base_link")
    assert driver.get_clock().now().nanoseconds == 5_000_000_000
    # sent as serialized bytes refilled in place: the message odometry() makes, field
    # for field (the covariances and the rest as a fresh Odometry has them)
    assert last == sim.node.odometry()


def test_serialized_fields_are_found_or_refused() -> None:
    from rclpy.serialization import deserialize_message

    from rosbook.runtime.cdr import CdrFields

    msg = Odometry()
    msg.header.frame_id = "odom"
    with pytest.raises(TypeError, match="pose.covariance is a double\\[36\\]"):
        CdrFields(msg, ("pose.covariance",))
    fields = CdrFields(msg, ("header.stamp.nanosec", "twist.twist.angular.z"))
    sent = deserialize_message(fields.pack(7, -0.5), Odometry)
    assert (sent.header.stamp.nanosec, sent.twist.twist.angular.z) == (7, -0.5)
    assert sent.header.frame_id == "odom" and sent.pose == msg.pose
    assert fields.unpack(fields.pack(3, 2.5)) == (3, 2.5)
    with pytest.raises(TypeError, match="header.frame_id is a string"):
        CdrFields(msg, ("header.frame_id",))


@pytest.mark.usefixtures("reset_session")
def test_robot_stops_when_cmd_vel_goes_quiet() -> None:
    sim = Simulation(World(arena=None))
    ConstantDriver(0.4, 0.0, stop_at=1.0)
    sim.run(1.2)
    assert sim.physics.twist[0] == pytest.approx(0.4)  # the last command still holds
    sim.run(0.4)
    traj = sim.trajectory
    x_at = dict(zip(np.round(traj.t, 6), traj.x))
    # the last command came at t = 1.0 s: the robot moves until 1.5 s, then stands
    assert x_at[1.495] < x_at[1.5] == x_at[1.505] == x_at[1.6]
    x = sim.physics.pose.x
    sim.run(2.0)
    assert sim.physics.pose.x == x == pytest.approx(0.4 * (1.5 - 0.02), abs=0.01)


@pytest.mark.usefixtures("reset_session")
def test_scan_topic_reports_the_wall_ahead() -> None:
    sim = Simulation(World(arena=(-1.0, -1.0, 2.0, 1.0)))
    driver = ConstantDriver(0.0, 0.0)
    sim.run(1.0)
    assert len(driver.scans) == 6  # 5 Hz, and one at t = 0
    scan = driver.scans[-1]
    assert len(scan.ranges) == 360 and scan.header.frame_id == "laser_frame"
    ahead = round((0.0 - scan.angle_min) / scan.angle_increment)
    assert scan.ranges[ahead] == pytest.approx(2.0, abs=1e-5)


@pytest.mark.usefixtures("reset_session")
def test_lockstep_run_is_the_same_every_time() -> None:
    def path() -> bytes:
        sim = Simulation(World(), seed=3, wheel_noise=0.05)
        ConstantDriver(0.3, -0.4, stop_at=2.0)
        sim.run(3.0)
        return sim.trajectory.as_array().tobytes()

    assert path() == path()


class Stepper(Node):
    """A service in lockstep: each call moves a counter; a 50 Hz timer calls it (sync or async)."""

    def __init__(self, awaiting: bool) -> None:
        super().__init__("stepper")
        self.count = 0
        self.answers: list[tuple[float, str]] = []
        # Reentrant: the coroutine's timer holds the default group while it awaits.
        group = ReentrantCallbackGroup()
        self.create_service(Trigger, "step", self.on_step, callback_group=group)
        self.client = self.create_client(Trigger, "step", callback_group=group)
        self.create_timer(0.02, self.on_timer_async if awaiting else self.on_timer)

    def on_step(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        self.count += 1
        response.message = str(self.count)
        return response

    def now(self) -> float:
        return self.get_clock().now().nanoseconds / 1e9

    def on_timer(self) -> None:
        asked = self.now()
        future = self.client.call_async(Trigger.Request())
        future.add_done_callback(lambda f: self.answers.append((asked, f.result().message)))

    async def on_timer_async(self) -> None:
        asked = self.now()
        response = await self.client.call_async(Trigger.Request())
        self.answers.append((asked, response.message))


@pytest.mark.usefixtures("reset_session")
@pytest.mark.parametrize("awaiting", [False, True], ids=["done-callback", "coroutine"])
def test_services_and_clients_answer_within_the_lockstep_tick(awaiting: bool) -> None:
    def answers() -> list[tuple[float, str]]:
        sim = Simulation(World(arena=None))
        stepper = Stepper(awaiting)
        sim.run(1.0)
        return stepper.answers

    got = answers()
    # every call of the tick at t is answered before time moves on, in order
    assert got == [(pytest.approx(0.02 * k), str(k)) for k in range(1, 51)]
    assert answers() == got


@pytest.mark.usefixtures("reset_session")
def test_a_tick_needs_no_wait_of_rclpys_executor(monkeypatch: pytest.MonkeyPatch) -> None:
    """The controller's timer and messages are served without rclpy's per-callback waits."""
    import rosbook.runtime.callbacks as callbacks
    import rosbook.sim.node as sim_node

    rounds = []
    full_round = callbacks.run_round
    counted = lambda ex: rounds.append(1) or full_round(ex)  # noqa: E731
    monkeypatch.setattr(callbacks, "run_round", counted)
    monkeypatch.setattr(sim_node, "run_round", counted)
    waits = []
    spin_once = WakingExecutor.spin_once
    monkeypatch.setattr(
        WakingExecutor, "spin_once", lambda ex, *a, **k: waits.append(1) or spin_once(ex, *a, **k)
    )
    sim = Simulation(World(arena=None))
    driver = ConstantDriver(0.3, 0.6)
    sim.run(2.0)
    assert len(driver.ticks) == 100 and sim.node.commands == 100
    # the first round (the executor's own start) and one every EVENTS_EVERY_TICKS ticks
    assert len(rounds) <= 1 + 100 // sim_node.EVENTS_EVERY_TICKS
    assert waits == []  # waiting for /clock to arrive: rcl's wait on a kept wait set


@pytest.mark.usefixtures("reset_session")
def test_a_controller_that_destroys_a_timer_in_a_callback_drives_on() -> None:
    """A one-shot start: the odom callback destroys the node's own timer. The lockstep
    runner knew its timers from before and asked rcl whether the destroyed one was due
    ("failed to check timer ready: timer argument is null"): the run ended there."""

    class StartsOnce(Node):
        def __init__(self) -> None:
            super().__init__("starts_once")
            self.pub = self.create_publisher(Twist, "cmd_vel", 10)
            self.create_subscription(Odometry, "odom", self.on_odom, 10)
            self.start: Any = self.create_timer(0.5, lambda: None)
            self.create_timer(0.02, lambda: self.pub.publish(Twist()))
            self.odom = 0

        def on_odom(self, msg: Odometry) -> None:
            self.odom += 1
            if self.odom == 10:
                self.destroy_timer(self.start)

    sim = Simulation(World(arena=None))
    node = StartsOnce()
    sim.run(2.0)
    assert node.odom == 101 and sim.node.commands == 100


def test_a_start_pose_inside_a_wall_is_refused() -> None:
    with pytest.raises(ValueError, match="overlaps a wall or an obstacle"):
        DiffDriveSim(World(arena=(-1.0, -1.0, 1.0, 1.0), start=(-0.6, 0.0, 0.0)))


def test_path_plot_and_animation_are_drawn_from_the_run() -> None:
    from rosbook.sim.plot import animate, plot_path, png

    sim = DiffDriveSim(World())
    sim.command(0.3, 0.5)
    sim.run(2.0)
    assert png(plot_path(sim.trajectory, sim.world, goal=(1.0, 1.0))).startswith(b"\x89PNG")
    html = animate(sim.trajectory, sim.world, fps=5, size=2.0, dpi=30).to_jshtml()
    assert "frames[10]" in html and "frames[11]" not in html  # t = 0, 0.2, ..., 2.0
    sampled = sim.trajectory.sample(0.5)
    assert sampled.t == pytest.approx([0.0, 0.5, 1.0, 1.5, 2.0])


def test_simulator_runs_as_a_process_in_real_time_and_exits_cleanly_on_ctrl_c(
    session: object,
) -> None:
    from rosgraph_msgs.msg import Clock

    from rosbook.labs import probes as checks
    from rosbook.sim import node as sim_node

    clock = checks.Probe("/clock", Clock)
    odom = checks.Probe("odom", Odometry)
    with checks.run_script(sim_node.__file__) as run:
        checks.wait_for_script_publisher(run, odom)
        command = checks.Sender("cmd_vel", Twist)
        command.wait_for_subscriber()
        drive = Twist()
        drive.linear.x = 0.5
        for _ in range(10):
            command.pub.publish(drive)
            ros.spin_for(0.05)
        ros.spin_for(0.2)
        checks.assert_clean_exit(run)
    stamps = [m.clock.sec + m.clock.nanosec * 1e-9 for m in clock.received.messages]
    assert len(stamps) > 20 and stamps == sorted(stamps)
    assert max(m.pose.pose.position.x for m in odom.received.messages) > 0.1


def test_twin_frames_carry_the_urdf_base_pose_and_the_wheel_angles() -> None:
    sim = DiffDriveSim(OPEN)
    sim.command(0.0, math.pi / 2)  # a quarter turn on the spot in 1 s
    sim.run(1.0)
    frames = sim.twin_frames(period=0.5)
    assert [f.t for f in frames] == pytest.approx([0.0, 0.5, 1.0])
    last = frames[-1]
    # base_link, the axle's middle, turned on the spot: still at the origin, facing +y
    assert (last.x, last.y, last.yaw) == pytest.approx((0.0, 0.0, math.pi / 2), abs=1e-9)
    spin = math.pi / 2 * 0.2 / 0.04  # w L/2 / r for 1 s
    assert (last.left_wheel, last.right_wheel) == pytest.approx((-spin, spin))
