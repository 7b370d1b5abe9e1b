"""Checks that lab 5's test cells run: a student's driving node against the simulator.

Every run is headless and on simulated time (the simulator publishes ``/clock`` and
steps in lockstep with the student's node), so it is exact, repeatable and bounded:
a node that never stops still ends when the simulated seconds are up, and a run ends
early once its verdict is known (a collision, or the robot standing still at its
target). The speed of the machine never decides a verdict: the only wall-clock limit
guards against a hang, is generous, and raises ``TimeoutError`` ("timeout"). Failures are
``AssertionError`` messages that name the likely mistake; the path plot (and, once per
lab, the recorded 3D twin) goes into the cell's output so the feedback shows what the
robot did.

When graded, the same test cells run in the judge (``rosbook.labs.remote``): the
student's node is a handle, built and spun in the kernel, and the simulator runs in the
judge, in lockstep with the kernel tick by tick (``drive``'s graded branch); the
figures go into the judge's verdict (``probes.show``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node

from rosbook.labs import probes as checks
from rosbook.labs.deferral import deferrable
from rosbook.labs.lockstep import (
    LOCKSTEP_GUARD_S,
    await_discovered_by,
    remote_clock,
    wait_for,
    wait_until_discovered,
)
from rosbook.labs.remote import Judgement, JudgeTimeout, KernelError, is_student, judgement
from rosbook.runtime.session import ros
from rosbook.sim.diff_drive import body_twist as reference_body_twist
from rosbook.sim.diff_drive import wheel_speeds as reference_wheel_speeds
from rosbook.sim.node import TICK_S, DiffDriveSimNode, SimulatedRobot, Simulation
from rosbook.sim.physics import DiffDriveSim, Trajectory, World

#: Wall-clock guard of one simulated run in a check (seconds): against hangs only. The
#: grader's cell timeout usually comes first and reports the cell as timed out.
RUN_HANG_GUARD_S = 600.0
#: What the graded checks show figures with: the judge imports them while the kernel
#: starts (``autograder.judge.prepare``), not in the first test cell.
PRELOAD = ("IPython.core.formatters", "IPython.display", "rosbook.viz.twin")
#: Wall-clock guard of one graded run (seconds): against a node whose callbacks block,
#: never a verdict on speed (the solution's runs take a few seconds on a quiet machine);
#: no longer than the grader's limit on a cell (``Judgement.guard``).
JUDGED_RUN_GUARD_S = 90.0


@dataclass
class Finish:
    """When a run's verdict is known before its simulated seconds are up.

    The robot stood still for ``still`` seconds within ``tolerance`` of ``target`` after
    having left it or been away from it; or it collided (a failure either way).
    """

    target: tuple[float, float]
    tolerance: float
    still: float

    def until(self, sim: SimulatedRobot) -> Callable[[], bool]:
        """The condition for ``sim.run(seconds, until=...)``: true once the verdict is known."""
        return _Watch(sim, self)


class _Watch:
    """Follows the robot tick by tick and says when the run's verdict is known."""

    def __init__(self, sim: SimulatedRobot, finish: Finish) -> None:
        self.sim = sim
        self.finish = finish
        self.pose = sim.physics.pose
        self.moved_at = sim.now
        self.away = self._distance() > finish.tolerance

    def _distance(self) -> float:
        pose = self.sim.physics.pose
        return math.hypot(pose.x - self.finish.target[0], pose.y - self.finish.target[1])

    def __call__(self) -> bool:
        if self.sim.physics.collisions:
            return True
        pose = self.sim.physics.pose
        if (pose.x, pose.y, pose.yaw) != (self.pose.x, self.pose.y, self.pose.yaw):
            self.pose = pose
            self.moved_at = self.sim.now
        distance = self._distance()
        self.away = self.away or distance > self.finish.tolerance
        still_for = self.sim.now - self.moved_at
        return self.away and distance <= self.finish.tolerance and still_for >= self.finish.still


@dataclass
class DriveRun:
    """What happened when a student's node drove the simulated robot (when graded,
    ``node`` is the ``RemoteNode`` of the student's node in the kernel)."""

    sim: SimulatedRobot
    node: Node
    world: World
    seconds: float

    @property
    def trajectory(self) -> Trajectory:
        return self.sim.trajectory

    @property
    def path(self) -> np.ndarray:
        """Columns t, x, y, yaw of base_link at every physics step."""
        return self.trajectory.as_array()[:, :4]


def drive(
    factory: Callable[..., Node],
    *args: Any,
    world: World,
    seconds: float,
    seed: int = 0,
    finish: Finish | None = None,
    **kwargs: Any,
) -> DriveRun:
    """Start the simulator in ``world``, build the student's node, run ``seconds``.

    With ``finish`` the run ends as soon as its verdict is known (see :class:`Finish`).
    When graded, ``factory`` is a handle to the student's class: the node runs in the
    kernel and the simulator here (``judged_drive``).
    """
    if is_student(factory):
        if args:
            raise TypeError("drive: pass a node's arguments by name when it is graded")
        return judged_drive(
            judgement(), factory, world=world, seconds=seconds, seed=seed, finish=finish, **kwargs
        )
    sim = Simulation(world, seed=seed)
    node = checks.make_node(factory, *args, **kwargs)
    checks.node_publishes(node, "cmd_vel", Twist)
    checks.node_subscribes(node, "odom", Odometry)
    until = finish.until(sim) if finish is not None else None
    try:
        sim.run(seconds, until=until, wall_timeout=RUN_HANG_GUARD_S)
    except TimeoutError as exc:
        raise TimeoutError(blocked(str(exc))) from None
    except Exception as exc:  # a callback of the student's node raised
        raise AssertionError(
            callback_raised(f"{type(exc).__name__}: {exc} ({checks._where(exc)})")
        ) from None
    assert_commanded(sim.node.commands, seconds)
    return DriveRun(sim, node, world, sim.now)


class JudgedSim(SimulatedRobot):
    """The simulated robot in the judge's process (``DriveRun.sim`` of a graded run): the
    physics and its ROS node, stepped by ``judged_drive`` in lockstep with the kernel."""

    def __init__(self, world: World, seed: int = 0) -> None:
        physics = DiffDriveSim(world, seed=seed)
        super().__init__(physics, DiffDriveSimNode(physics))
        #: Sensor messages published so far, by topic.
        self.sent = {"/odom": 0, "/scan": 0}
        for topic, publisher in (("/odom", self.node.odom_pub), ("/scan", self.node.scan_pub)):
            publisher.publish = self._counting(topic, publisher.publish)  # type: ignore[method-assign]

    def _counting(self, topic: str, publish: Callable[[Any], None]) -> Callable[[Any], None]:
        def counted(msg: Any) -> None:
            publish(msg)
            self.sent[topic] += 1

        return counted

    def close(self) -> None:
        self.node.destroy_node()


@contextmanager
def callbacks_explained() -> Iterator[None]:
    """A callback of the student's node that raised in the kernel: the lab's message."""
    try:
        yield
    except KernelError as exc:
        raise checks.CheckFailed(callback_raised(str(exc))) from None


def judged_drive(
    j: Judgement,
    factory: Any,
    *,
    world: World,
    seconds: float,
    seed: int = 0,
    finish: Finish | None = None,
    **kwargs: Any,
) -> DriveRun:
    """``drive`` when graded: the student's ``factory(**kwargs)`` is built in the kernel
    on simulated time (its ``parameter_overrides``, the test cell's own ``Parameter``
    objects, cross as plain names and values) and drives the judge's simulated robot,
    tick by tick as ``Simulation`` runs it in one process:

    1. the physics steps one tick and the sensors are published; the ``odom`` reading
       carries the new time: once the node's subscription has taken it, the kernel
       moves the node's ``/clock`` to its stamp (``JudgeAgent.follow_clock``'s gate), so
       the node's callback sees the reading before its timers at that time run;
    2. once the kernel says the node's due timers ran, and every ``cmd_vel`` it says it
       published has arrived, the simulator takes the commands and the next tick begins.

    So the node sees what it would see in the kernel's own simulator, the path is the
    same to the bit, and only hang guards (a timeout, never wrong) use the wall clock."""
    ros.reset()
    sim = JudgedSim(world, seed=seed)
    try:
        overrides = kwargs.pop("parameter_overrides", None) or ()
        parameters = {p.name: p.value for p in overrides} or None
        node = j.start_node(factory, sim_time=True, parameters=parameters, **kwargs)
        checks.node_publishes(node, "cmd_vel", Twist)
        checks.node_subscribes(node, "odom", Odometry)
        name = node.get_name()
        wait_for(
            lambda: (
                sim.node.odom_pub.get_subscription_count() > 0
                and sim.node.cmd_sub.get_publisher_count() > 0
            ),
            sim.node,
            what=f"node '{name}' and the simulator did not find each other on odom and cmd_vel",
            guard=LOCKSTEP_GUARD_S,
        )
        await_discovered_by(j, sim.node, "/odom", name)  # its first odom is not lost
        until = finish.until(sim) if finish is not None else lambda: False
        with callbacks_explained(), remote_clock(j, name, gate="/odom") as clock:
            wait_until_discovered(clock.acked, clock.node, "/cmd_vel", sim.node.get_name(), name)

            def commands_arrived(published: dict[str, int]) -> bool:
                sim.node.take_commands()
                return sim.node.commands >= published.get("/cmd_vel", 0)

            def odom_taken() -> bool:
                return clock.acked[-1]["taken"].get("/odom", 0) >= sim.sent["/odom"]

            clock.arrived = commands_arrived
            advance = False
            guard = j.guard(JUDGED_RUN_GUARD_S)
            give_up = time.monotonic() + guard
            while sim.now < seconds - 1e-9 and not (advance and until()):
                if time.monotonic() > give_up:
                    raise JudgeTimeout(
                        blocked(
                            f"simulating {seconds:g} s took longer than {guard:g} s "
                            f"of wall time (stopped at t={sim.now:.2f} s)."
                        )
                    )
                if advance:
                    sim.node.advance(TICK_S)
                    sim.node.publish_sensors()
                    clock.advance(sim.now - clock.now, clock.node, step=sim.now - clock.now)
                else:  # the first reading, at the time the node starts at
                    sim.node.publish_sensors(force=True)
                    clock.wait_for(
                        odom_taken,
                        what=f"node '{name}' did not take odom at t = {sim.now:g} s",
                        guard=LOCKSTEP_GUARD_S,
                    )
                advance = True
        assert_commanded(sim.node.commands, seconds)
        return DriveRun(sim, node, world, sim.now)  # type: ignore[arg-type]
    finally:
        sim.close()


def blocked(reason: str) -> str:
    """The message for a run stopped by its hang guard (``reason``: which, and when)."""
    return (
        f"{reason} Does a callback of your node block (a loop waiting for odom, "
        "time.sleep)? Let the timer and subscription callbacks return quickly."
    )


def assert_commanded(commands: int, seconds: float) -> None:
    """Some ``cmd_vel`` arrived at the simulator in the run of ``seconds``."""
    if commands == 0:
        raise AssertionError(
            f"no Twist arrived on 'cmd_vel' in {seconds:g} s of simulated time: does a "
            "timer of your node publish geometry_msgs/msg/Twist on 'cmd_vel'?"
        )


def callback_raised(what: str) -> str:
    """The message for a callback of the student's node that raised (``what``: the
    exception's type and message, and where)."""
    return f"a callback of your node raised {what}"


def path_image(
    run: DriveRun,
    title: str,
    goal: tuple[float, float] | None = None,
    marks: Sequence[tuple[float, float]] = (),
) -> Any:
    """The run's path as a small PNG (an ``IPython.display.Image``): what ``show_path``
    shows."""
    from IPython.display import Image

    from rosbook.sim.plot import plot_path, png

    fig = plot_path(run.trajectory, run.world, title=title, goal=goal, marks=marks, size=3.2)
    return Image(png(fig, dpi=60))


def show_path(
    run: DriveRun,
    title: str,
    goal: tuple[float, float] | None = None,
    marks: Sequence[tuple[float, float]] = (),
) -> None:
    """Display the run's path as a small PNG in the cell's output (the feedback)."""
    checks.show(path_image(run, title, goal, marks))


#: Frames per simulated second of the twin shown in the feedback (small and smooth enough).
TWIN_FPS = 10


def twin_scene(run: DriveRun, height: int = 320) -> Any:
    """The run's recorded 3D twin (the URDF robot replaying the drive), a ``Scene``.

    Outside the book a scene carries its own copy of the MeshCat viewer (about 1 MB of
    JavaScript), so a lab shows the twin once, for one run; the path plots show the rest.
    It renders in JupyterLab and in nbgrader's feedback page (a self-contained iframe).
    """
    from rosbook.viz import twin

    return twin.record(run.sim.physics, fps=TWIN_FPS, height=height)


def show_twin(run: DriveRun, height: int = 320) -> None:
    """Display the run's recorded 3D twin (``twin_scene``) in the cell's output."""
    checks.show(twin_scene(run, height))


# -- kinematics ------------------------------------------------------------------------


def _pair(fn: Callable[..., Any], call: str, *args: float) -> tuple[float, float]:
    try:
        got = fn(*args)
    except Exception as exc:
        if is_student(fn):  # the judge's call says what the kernel raised, or timed out
            raise
        raise AssertionError(f"{call} raised {type(exc).__name__}: {exc}") from None
    try:
        a, b = got
        return float(a), float(b)
    except (TypeError, ValueError):
        raise AssertionError(f"{call} returned {got!r}; expected a pair of numbers") from None


def _close(a: Sequence[float], b: Sequence[float]) -> bool:
    return all(math.isclose(x, y, rel_tol=1e-6, abs_tol=1e-9) for x, y in zip(a, b))


def assert_wheel_speeds(fn: Callable[..., Any], v: float, w: float, r: float, sep: float) -> None:
    """``fn(v, w, r, sep)`` gives (left, right) in rad/s, naming the usual mistakes."""
    call = f"wheel_speeds({v}, {w}, {r}, {sep})"
    got = _pair(fn, call, v, w, r, sep)
    want = reference_wheel_speeds(v, w, r, sep)
    if _close(got, want):
        return
    seen = f"{call} returned ({got[0]:.4g}, {got[1]:.4g}), expected ({want[0]:.4g}, {want[1]:.4g})"
    if _close(got, want[::-1]):
        raise AssertionError(
            f"{seen}: left and right are swapped. Turning left (w > 0, counter-clockwise) "
            "needs the RIGHT wheel faster: right = (v + w L/2) / r"
        )
    if _close(got, (want[0] / 2, want[1] / 2)):
        raise AssertionError(
            f"{seen}: half the right speeds. Is the wheel radius used as a diameter "
            "(dividing by 2 r)? A wheel of radius r rolls r metres per radian"
        )
    if _close(got, (want[0] * 2, want[1] * 2)):
        raise AssertionError(
            f"{seen}: twice the right speeds. Is the radius halved (dividing by r / 2)? "
            "A wheel of radius r rolls r metres per radian"
        )
    if _close(got, (want[0] * r, want[1] * r)) or _close(got, (want[0] * r * r, want[1] * r * r)):
        raise AssertionError(f"{seen}: wheel speeds in rad/s are metres per second divided by r")
    if _close(got, reference_wheel_speeds(v, 2 * w, r, sep)):
        raise AssertionError(f"{seen}: the turning part is twice too big; each wheel is L/2 away")
    raise AssertionError(f"{seen}: left = (v - w L/2) / r, right = (v + w L/2) / r")


def assert_body_twist(
    fn: Callable[..., Any], left: float, right: float, r: float, sep: float
) -> None:
    """``fn(left, right, r, sep)`` gives (v, w), naming the usual mistakes."""
    call = f"body_twist({left}, {right}, {r}, {sep})"
    got = _pair(fn, call, left, right, r, sep)
    want = reference_body_twist(left, right, r, sep)
    if _close(got, want):
        return
    seen = f"{call} returned ({got[0]:.4g}, {got[1]:.4g}), expected ({want[0]:.4g}, {want[1]:.4g})"
    if _close(got, (want[0], -want[1])):
        raise AssertionError(
            f"{seen}: w has the wrong sign, so left and right are swapped. The robot turns "
            "left (w > 0) when the right wheel is faster: w = r (right - left) / L"
        )
    if _close(got, (want[0] * 2, want[1] * 2)) or _close(got, (want[0] / 2, want[1] / 2)):
        raise AssertionError(
            f"{seen}: off by a factor of 2. Radius and diameter confused? "
            "v = r (right + left) / 2 and w = r (right - left) / L with r the radius"
        )
    raise AssertionError(f"{seen}: v = r (right + left) / 2, w = r (right - left) / L")


# -- driving ---------------------------------------------------------------------------


def _start_frame(run: DriveRun) -> tuple[float, float, float]:
    return run.world.start


def square_corners(run: DriveRun, side: float) -> list[tuple[float, float]]:
    """The square's corners in the world, turning left from the start pose."""
    x0, y0, yaw0 = _start_frame(run)
    c, s = math.cos(yaw0), math.sin(yaw0)
    local = [(side, 0.0), (side, side), (0.0, side), (0.0, 0.0)]
    return [(x0 + c * px - s * py, y0 + s * px + c * py) for px, py in local]


def drove_away(run: DriveRun, goal: tuple[float, float], margin: float = 0.3) -> bool:
    """Whether the robot got ``margin`` metres farther from ``goal`` than it started."""
    path = run.path
    distance = np.hypot(path[:, 1] - goal[0], path[:, 2] - goal[1])
    return bool(np.max(distance) > distance[0] + margin)


def assert_no_collision(run: DriveRun, goal: tuple[float, float] | None = None) -> None:
    """No contact with a wall or an obstacle; with a ``goal``, say if it drove away first."""
    hits = run.sim.physics.collisions
    if not hits:
        return
    first = hits[0]
    where = (
        f"the robot hit a wall or an obstacle at t={first.t:.2f} s near "
        f"({first.x:.2f}, {first.y:.2f}) ({len(hits)} collision(s))"
    )
    if goal is not None and drove_away(run, goal):
        raise AssertionError(
            f"{where} after driving AWAY from the goal {goal}: the heading towards the goal "
            "is wrong when the goal is behind the robot. Is it math.atan(dy / dx)? atan only "
            "gives angles in (-pi/2, pi/2) and loses the quadrant; math.atan2(dy, dx) gives "
            "the full circle"
        )
    raise AssertionError(
        f"{where}: slow down and stop in time; remember the base reaches 0.1 m ahead of "
        "and 0.5 m behind the axle"
    )


def assert_square(run: DriveRun, side: float, tolerance: float = 0.1) -> None:
    """The path visits the corners in order (turning left) and ends at the start."""
    path = run.path
    t, x, y = path[:, 0], path[:, 1], path[:, 2]
    index = 0
    for k, (cx, cy) in enumerate(square_corners(run, side), start=1):
        distance = np.hypot(x[index:] - cx, y[index:] - cy)
        near = np.nonzero(distance <= tolerance)[0]
        if k < 4 and near.size == 0:
            closest = int(np.argmin(distance))
            hint = ""
            if k == 2:
                x0, y0, yaw0 = run.world.start
                right_turn = (
                    x0 + side * (math.cos(yaw0) + math.sin(yaw0)),
                    y0 + side * (math.sin(yaw0) - math.cos(yaw0)),
                )
                if np.min(np.hypot(x - right_turn[0], y - right_turn[1])) <= tolerance:
                    hint = " It turned right: the square turns left (w > 0, counter-clockwise)."
            raise AssertionError(
                f"the robot never came within {tolerance} m of corner {k} of the {side:g} m "
                f"square, at ({cx:.2f}, {cy:.2f}); closest {distance[closest]:.2f} m at "
                f"t={t[index + closest]:.1f} s.{hint} Check the side length and the 90 degree "
                "turns (pi/2 rad, measured from odom)."
            )
        if k < 4:
            index += int(near[0])
    end = math.hypot(x[-1] - x[0], y[-1] - y[0])
    if end > tolerance:
        raise AssertionError(
            f"after the square the robot stopped at ({x[-1]:.2f}, {y[-1]:.2f}), {end:.2f} m "
            f"from its start ({x[0]:.2f}, {y[0]:.2f}); expected within {tolerance} m"
        )


def assert_stopped(run: DriveRun, last: float = 2.0) -> None:
    """The robot stood still for the last ``last`` seconds of the run."""
    path = run.path
    tail = path[path[:, 0] >= path[-1, 0] - last]
    moved = float(np.sum(np.hypot(np.diff(tail[:, 1]), np.diff(tail[:, 2]))))
    turned = float(np.sum(np.abs(np.diff(tail[:, 3]))))
    if moved > 0.005 or turned > 0.01:
        raise AssertionError(
            f"the robot was still moving in the last {last:g} s of the {run.seconds:g} s run "
            f"({moved:.2f} m, {turned:.2f} rad): when the task is done, publish a zero Twist "
            "(or stop publishing) and keep it stopped; the node never stops"
        )


def turn_reversals(run: DriveRun, threshold: float = 0.05) -> int:
    """How often the turn rate changed sign (|w| above ``threshold`` rad/s on both sides)."""
    path = run.path
    step = max(1, int(round(0.02 / run.sim.physics.dt)))
    yaw = np.unwrap(path[::step, 3])
    w = np.diff(yaw) / (step * run.sim.physics.dt)
    signs = np.sign(w[np.abs(w) > threshold])
    return int(np.sum(signs[1:] != signs[:-1]))


def assert_not_oscillating(run: DriveRun, limit: int = 12) -> None:
    reversals = turn_reversals(run)
    if reversals > limit:
        raise AssertionError(
            f"the turn rate changed direction {reversals} times: the controller oscillates "
            "(steering too hard, or bang-bang). Use w = k * heading error with a moderate "
            "gain (about 1-3), wrap the error into [-pi, pi] and limit w"
        )


def assert_goal(run: DriveRun, goal: tuple[float, float], tolerance: float = 0.05) -> None:
    """The run ends within ``tolerance`` of ``goal``."""
    path = run.path
    distance = np.hypot(path[:, 1] - goal[0], path[:, 2] - goal[1])
    final = float(distance[-1])
    if final <= tolerance:
        return
    closest = int(np.argmin(distance))
    if distance[closest] <= tolerance:
        raise AssertionError(
            f"the robot passed within {distance[closest]:.3f} m of the goal {goal} at "
            f"t={path[closest, 0]:.1f} s but ended {final:.2f} m away: stop when the "
            f"goal is within {tolerance} m (and slow down near it)"
        )
    raise AssertionError(
        f"the robot ended at ({path[-1, 1]:.2f}, {path[-1, 2]:.2f}), {final:.2f} m from the "
        f"goal {goal} (closest {distance[closest]:.2f} m); expected within {tolerance} m. "
        "Is the 'goal' parameter read (x, y, yaw), and the heading error atan2(dy, dx) - yaw?"
    )


def assert_heading(run: DriveRun, yaw: float, tolerance: float = 0.05) -> None:
    """The run ends facing ``yaw`` (radians, odom frame) within ``tolerance``."""
    final = float(run.path[-1, 3])
    error = math.remainder(final - yaw, 2 * math.pi)
    if abs(error) <= tolerance:
        return
    hint = (
        " Is the final turn missing? Once at the goal, turn on the spot until the heading "
        "error remainder(goal_yaw - yaw, 2 pi) is small, then stop"
        if abs(error) > 0.3
        else " Slow the final turn down near the goal heading so it does not overshoot"
    )
    raise AssertionError(
        f"the robot ended facing {final:.3f} rad, {error:+.3f} rad from the goal heading "
        f"{yaw:.3f} rad; expected within {tolerance} rad.{hint}"
    )


deferrable(globals())
