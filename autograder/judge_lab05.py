"""Lab 5's checks as the judge runs them: the simulator runs in the judge.

The kinematics functions are called in the kernel with the judge's own inputs and their
return values judged here. For the driving tasks the judge runs the simulator itself
(physics, ``odom`` and ``scan`` out, ``cmd_vel`` in, ``/clock``) while the student's
node runs in the kernel on the judge's ``/clock`` (``RemoteClock``), in lockstep on
simulated time, tick by tick as ``rosbook.sim.node.Simulation`` does in one process:

1. the physics steps one tick and the sensors are published; the ``odom`` reading
   carries the new time: once the node's subscription has taken it, the kernel moves
   the node's ``/clock`` to its stamp, so the node's callback sees the reading before
   its timers at that time run;
2. once the kernel says the node's due timers ran, and every ``cmd_vel`` it says it
   published has arrived, the simulator takes the commands and the next tick begins.

So the node sees what it would see in the kernel's own simulator, the run is the same
every time, and only hang guards (reported as "timeout") use the wall clock. The path
is the judge's own record; the verdicts use the assertions of ``rosbook.labs.lab05``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry

from autograder.judge import CheckFailed, Judgement, JudgeTimeout, KernelError
from rosbook.labs import lab05 as drive_checks
from rosbook.labs.lockstep import (
    LOCKSTEP_GUARD_S,
    RemoteNode,
    await_discovered_by,
    remote_clock,
    require_endpoint,
    require_name,
    wait_for,
    wait_until_discovered,
)
from rosbook.runtime.session import ros
from rosbook.sim.node import DiffDriveSimNode
from rosbook.sim.physics import Box, DiffDriveSim, Trajectory, World

#: Wall-clock guard of one run (seconds): against a node whose callbacks block, never a
#: verdict on speed (the solution's runs take a few seconds on a quiet machine); no
#: longer than the grader's limit on a cell (``Judgement.guard``).
DRIVE_GUARD_S = 90.0
#: The simulator's tick (seconds of simulated time between the node's turns), as in
#: ``Simulation``: the controllers' 50 Hz timers and ``odom`` at 50 Hz.
TICK_S = 0.02


class JudgeSim:
    """The simulated robot in the judge's process (``DriveRun.sim`` of the checks)."""

    def __init__(self, world: World, seed: int = 0) -> None:
        self.physics = DiffDriveSim(world, seed=seed)
        self.node = DiffDriveSimNode(self.physics)
        #: Sensor messages published so far, by topic.
        self.sent = {"/odom": 0, "/scan": 0}
        for topic, publisher in (("/odom", self.node.odom_pub), ("/scan", self.node.scan_pub)):
            publisher.publish = self._counting(topic, publisher.publish)  # type: ignore[method-assign]

    def _counting(self, topic: str, publish: Callable[[Any], None]) -> Callable[[Any], None]:
        def counted(msg: Any) -> None:
            publish(msg)
            self.sent[topic] += 1

        return counted

    @property
    def now(self) -> float:
        return self.physics.time

    @property
    def trajectory(self) -> Trajectory:
        return self.physics.trajectory

    def close(self) -> None:
        self.node.destroy_node()


@contextmanager
def callbacks_explained() -> Iterator[None]:
    """A callback of the student's node that raised in the kernel: the lab's message."""
    try:
        yield
    except KernelError as exc:
        raise CheckFailed(drive_checks.callback_raised(str(exc))) from None


def drive(
    j: Judgement,
    factory: str,
    *,
    world: World,
    seconds: float,
    finish: drive_checks.Finish,
    name: str,
    goal: tuple[float, float, float] | None = None,
    **kwargs: Any,
) -> drive_checks.DriveRun:
    """The student's ``factory(**kwargs)`` (with the ``goal`` parameter) drives the
    judge's simulated robot in ``world`` for ``seconds`` (or until ``finish``)."""
    ros.reset()
    sim = JudgeSim(world)
    try:
        parameters = {"goal": list(goal)} if goal is not None else None
        info = j.start_node(factory, sim_time=True, parameters=parameters, **kwargs)
        shown = ", ".join(f"{k}={v!r}" for k, v in kwargs.items())
        require_name(info, f"{factory}({shown})", name)
        require_endpoint(info, "/cmd_vel", Twist, "publisher")
        require_endpoint(info, "/odom", Odometry, "subscription")
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
        until = finish.until(sim)  # type: ignore[arg-type]
        with callbacks_explained(), remote_clock(j, name, gate="/odom") as clock:
            wait_until_discovered(clock.acked, clock.node, "/cmd_vel", sim.node.get_name(), name)

            def commands_arrived(published: dict[str, int]) -> bool:
                sim.node.take_commands()
                return sim.node.commands >= published.get("/cmd_vel", 0)

            def odom_taken() -> bool:
                return clock.acked[-1]["taken"].get("/odom", 0) >= sim.sent["/odom"]

            clock.arrived = commands_arrived
            advance = False
            guard = j.guard(DRIVE_GUARD_S)
            give_up = time.monotonic() + guard
            while sim.now < seconds - 1e-9 and not (advance and until()):
                if time.monotonic() > give_up:
                    raise JudgeTimeout(
                        drive_checks.blocked(
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
        drive_checks.assert_commanded(sim.node.commands, seconds)
        return drive_checks.DriveRun(sim, RemoteNode(name), world, sim.now)  # type: ignore[arg-type]
    finally:
        sim.close()


# -- the checks ------------------------------------------------------------------------


def check_wheel_speeds(j: Judgement) -> None:
    def wheel_speeds(*args: float) -> Any:
        return j.call_function("wheel_speeds", *args)

    def body_twist(*args: float) -> Any:
        return j.call_function("body_twist", *args)

    r, sep = 0.04, 0.4
    for v, w in [(0.2, 0.0), (0.0, 1.0), (0.3, 0.5)]:
        drive_checks.assert_wheel_speeds(wheel_speeds, v, w, r, sep)
    for left, right in [(5.0, 5.0), (-5.0, 5.0), (5.0, 10.0)]:
        drive_checks.assert_body_twist(body_twist, left, right, r, sep)
    for v, w, r, sep in [(-0.4, 0.3, 0.05, 0.3), (0.7, -1.1, 0.033, 0.287), (0.0, -2.0, 0.1, 0.5)]:
        drive_checks.assert_wheel_speeds(wheel_speeds, v, w, r, sep)
        left, right = wheel_speeds(v, w, r, sep)
        drive_checks.assert_body_twist(body_twist, left, right, r, sep)
        back = body_twist(left, right, r, sep)
        if not (math.isclose(back[0], v, abs_tol=1e-9) and math.isclose(back[1], w, abs_tol=1e-9)):
            raise CheckFailed(
                f"body_twist(*wheel_speeds({v}, {w}, {r}, {sep})) gave {back}, not ({v}, {w})"
            )


def check_square_driver(j: Judgement) -> None:
    for kwargs, name, side, world, seconds, title in (
        (
            {},
            "square_driver",
            1.0,
            World(arena=(-1.5, -1.5, 2.5, 2.5)),
            35.0,
            "SquareDriver(), side 1 m",
        ),
        (
            {"node_name": "square_b", "side": 0.6},
            "square_b",
            0.6,
            World(arena=(-2.0, -2.0, 2.0, 2.0), start=(0.5, -0.8, math.pi / 2)),
            30.0,
            "SquareDriver(side=0.6) from (0.5, -0.8) heading +y",
        ),
    ):
        start = world.start[:2]
        run = drive(
            j,
            "SquareDriver",
            world=world,
            seconds=seconds,
            finish=drive_checks.Finish(start, 0.1, still=2.1),
            name=name,
            **kwargs,
        )
        j.show(drive_checks.path_image(run, title, marks=drive_checks.square_corners(run, side)))
        drive_checks.assert_no_collision(run)
        drive_checks.assert_stopped(run)
        drive_checks.assert_square(run, side)


def check_go_to_pose(j: Judgement) -> None:
    for k, (kwargs, name, world, goal, seconds, oscillation, title) in enumerate(
        (
            (
                {},
                "go_to_pose",
                World(arena=(-1.0, -1.0, 2.5, 2.0)),
                (1.5, 1.0, math.pi / 2),
                25.0,
                True,
                "GoToPose, goal (1.5, 1.0), heading 1.57",
            ),
            (
                {"node_name": "go_b"},
                "go_b",
                World(arena=(-2.2, -1.5, 1.0, 1.6), boxes=(Box((0.3, 1.0), (0.4, 0.4)),)),
                (-1.5, 0.9, -math.pi / 2),
                25.0,
                True,
                "GoToPose, goal (-1.5, 0.9) behind the robot",
            ),
            (
                {},
                "go_to_pose",
                World(arena=(-1.0, -2.0, 1.5, 1.0), start=(0.0, 0.0, -math.pi / 2)),
                (0.6, -1.3, 3.0),
                20.0,
                False,
                "GoToPose, goal (0.6, -1.3) near the walls",
            ),
        )
    ):
        run = drive(
            j,
            "GoToPose",
            world=world,
            seconds=seconds,
            finish=drive_checks.Finish(goal[:2], 0.05, still=1.1),
            name=name,
            goal=goal,
            **kwargs,
        )
        j.show(drive_checks.path_image(run, title, goal=goal[:2]))
        if k == 0:  # the recorded 3D twin, once per lab
            j.show(drive_checks.twin_scene(run))
        drive_checks.assert_no_collision(run, goal[:2])
        if oscillation:
            drive_checks.assert_not_oscillating(run)
        drive_checks.assert_goal(run, goal[:2])
        drive_checks.assert_heading(run, goal[2])
        drive_checks.assert_stopped(run, last=1.0)


#: What the checks show figures with: the judge imports them before the first check.
PRELOAD = ("IPython.display", "IPython.core.formatters", "rosbook.sim.plot", "rosbook.viz.twin")

CHECKS = {
    "test_wheel_speeds": check_wheel_speeds,
    "test_square_driver": check_square_driver,
    "test_go_to_pose": check_go_to_pose,
}
