"""The simulator on ROS topics, with the conventions of a real mobile base.

``DiffDriveSimNode`` wraps a :class:`rosbook.sim.DiffDriveSim`:

- subscribes ``cmd_vel`` (``geometry_msgs/msg/Twist``: ``linear.x`` is v, ``angular.z`` w);
  a command holds until ``cmd_timeout`` simulated seconds pass without a new one, then
  the robot stops, as real bases do when their driver goes quiet;
- publishes ``odom`` (``nav_msgs/msg/Odometry``, frame ``odom`` -> ``base_link``, pose and
  twist) at ``odom_rate`` and ``scan`` (``sensor_msgs/msg/LaserScan``, frame
  ``laser_frame``) at ``scan_rate``, both stamped with simulated time;
- publishes ``/clock``: the simulator is the time source, as Gazebo is with
  ``use_sim_time``.

``Simulation`` runs it in lockstep with the nodes of the notebook session: each tick
steps the physics, publishes the sensors and ``/clock``, then runs every callback that
became ready (the controllers' timers, their ``cmd_vel``) before time moves on. A
controller at 50 Hz in the same process thus sees exactly what it would see on a robot
running in real time, only many times faster, and the same every run.

On a full ROS 2 install the same roles are played by Gazebo with ``ros_gz_bridge``
(``/cmd_vel``, ``/odom``, ``/scan``, ``/clock``).
"""

from __future__ import annotations

import array
import math
import operator
import time
from collections.abc import Callable

import numpy as np
import rclpy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.clock import Clock as RclpyClock
from rclpy.clock import ClockType
from rclpy.event_handler import (
    PublisherEventCallbacks,
    SubscriptionEventCallbacks,
)
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from sensor_msgs.msg import LaserScan

from rosbook.runtime.callbacks import Callbacks, WakingExecutor, run_round, timer_due
from rosbook.runtime.cdr import CdrFields
from rosbook.runtime.clock import CATCH_UP_TIMEOUT_S, LockstepClock, stamp, to_ns
from rosbook.runtime.session import Session, notebook_session
from rosbook.sim.physics import DiffDriveSim, LaserSpec, RobotGeometry, Trajectory, World

#: Seconds of simulated time without a ``cmd_vel`` after which the robot stops.
CMD_TIMEOUT_S = 0.5
#: Ticks between the lockstep loop's full rounds of rclpy's executor (for QoS events).
EVENTS_EVERY_TICKS = 50
#: What the simulator's ``odom`` says (the rest of the message never changes).
ODOM_FIELDS = (
    "header.stamp.sec",
    "header.stamp.nanosec",
    "pose.pose.position.x",
    "pose.pose.position.y",
    "pose.pose.orientation.z",
    "pose.pose.orientation.w",
    "twist.twist.linear.x",
    "twist.twist.angular.z",
)
#: The two numbers of a ``cmd_vel`` a differential drive obeys, in a serialized Twist.
TWIST_CDR = CdrFields(Twist(), ("linear.x", "angular.z"))


class DiffDriveSimNode(Node):
    """The simulated robot's driver: ``cmd_vel`` in; ``odom``, ``scan`` and ``/clock`` out."""

    def __init__(
        self,
        sim: DiffDriveSim,
        *,
        node_name: str = "diff_drive_sim",
        cmd_timeout: float = CMD_TIMEOUT_S,
        odom_rate: float = 50.0,
        scan_rate: float = 5.0,
    ) -> None:
        # The time source itself runs on wall time: it makes /clock, it does not follow it.
        # It keeps its wait set small (no parameter services, no QoS event handlers): the
        # lockstep loop waits on every node of the session several times per tick.
        super().__init__(
            node_name,
            parameter_overrides=[Parameter("use_sim_time", value=False)],
            start_parameter_services=False,
        )
        self.sim = sim
        self.cmd_timeout = cmd_timeout
        self.odom_period = 1.0 / odom_rate
        self.scan_period = 1.0 / scan_rate
        self.commands = 0
        self._last_cmd_time = -math.inf
        self._next_odom = 0.0
        self._next_scan = 0.0
        qos = QoSProfile(depth=10)
        quiet = PublisherEventCallbacks(use_default_callbacks=False)
        self.odom_pub = self.create_publisher(Odometry, "odom", qos, event_callbacks=quiet)
        self.scan_pub = self.create_publisher(LaserScan, "scan", qos, event_callbacks=quiet)
        # One message of each kind, refilled at every publish: no allocation per step.
        self._odom = Odometry()
        self._odom.header.frame_id = "odom"
        self._odom.child_frame_id = "base_link"
        # what a step changes, written into the serialized message (rclpy's conversion
        # of an Odometry costs as much as a physics step)
        self._odom_cdr = CdrFields(self._odom, ODOM_FIELDS)
        self._scan = LaserScan()
        self._scan.header.frame_id = "laser_frame"
        self.cmd_sub = self.create_subscription(
            Twist,
            "cmd_vel",
            self._on_cmd_vel,
            qos,
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False),
        )

    def take_commands(self) -> int:
        """Take every ``cmd_vel`` waiting in the subscription's queue, in order.

        The lockstep loop calls this instead of spinning the simulator's node, as a
        simulator drains its command queue once per step; it is what an executor does
        for a ready subscription (``take_message``, then the callback), without the
        cost of a wait set. Returns how many were taken.
        """
        taken = 0
        while True:
            with self.cmd_sub.handle:  # serialized: v and w read from their places
                got = self.cmd_sub.handle.take_message(self.cmd_sub.msg_type, True)
            if got is None:
                return taken
            self._command(*TWIST_CDR.unpack(got[0]))
            taken += 1

    def _on_cmd_vel(self, msg: Twist) -> None:
        self._command(msg.linear.x, msg.angular.z)

    def _command(self, v: float, w: float) -> None:
        self.commands += 1
        self._last_cmd_time = self.sim.time
        self.sim.command(v, w)

    @property
    def commanded(self) -> bool:
        """Whether a command is in force (received less than ``cmd_timeout`` ago)."""
        return self.sim.time - self._last_cmd_time < self.cmd_timeout - 1e-9

    def advance(self, seconds: float) -> None:
        """Step the physics by ``seconds``, stopping the robot when commands time out."""
        for _ in range(int(round(seconds / self.sim.dt))):
            if not self.commanded and self.sim.wheel_command != (0.0, 0.0):
                self.sim.command(0.0, 0.0)
            self.sim.step()

    def publish_sensors(self, force: bool = False) -> None:
        """Publish ``odom`` and ``scan`` if their period is due (or ``force``)."""
        t = self.sim.time
        if force or t >= self._next_odom - 1e-9:
            self.odom_pub.publish(self._odom_cdr.pack(*self._odom_values()))
            self._next_odom = t + self.odom_period
        if force or t >= self._next_scan - 1e-9:
            self.scan_pub.publish(self.laser_scan())
            self._next_scan = t + self.scan_period

    def odometry(self) -> Odometry:
        """The odometry now (the node's one ``Odometry`` message, refilled)."""
        msg = self._odom
        for path, value in zip(ODOM_FIELDS, self._odom_values(), strict=True):
            parent, _, name = path.rpartition(".")
            setattr(operator.attrgetter(parent)(msg), name, value)
        return msg

    def _odom_values(self) -> tuple[float, ...]:
        """The values of ``ODOM_FIELDS`` now: stamp, pose in the plane, twist."""
        pose = self.sim.pose
        v, w = self.sim.twist
        sec, nanosec = stamp(to_ns(self.sim.time))
        return (sec, nanosec, pose.x, pose.y, math.sin(pose.yaw / 2), math.cos(pose.yaw / 2), v, w)

    def laser_scan(self) -> LaserScan:
        """The scan now (the node's one ``LaserScan`` message, refilled)."""
        spec: LaserSpec = self.sim.laser
        msg = self._scan
        msg.header.stamp.sec, msg.header.stamp.nanosec = stamp(to_ns(self.sim.time))
        msg.angle_min = spec.angle_min
        msg.angle_max = spec.angle_max
        msg.angle_increment = spec.angle_increment
        msg.scan_time = self.scan_period
        msg.range_min = spec.range_min
        msg.range_max = spec.range_max
        msg.ranges = array.array("f", self.sim.scan().astype(np.float32).tobytes())
        return msg


def yaw_of(msg: Odometry) -> float:
    """The heading in an ``Odometry`` message (rotation about z)."""
    q = msg.pose.pose.orientation
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


#: Simulated seconds between a ``Simulation``'s turns of the nodes (the robot's drivers'
#: 50 Hz timers and ``odom`` at 50 Hz).
TICK_S = 0.02


class SimulatedRobot:
    """A simulated robot (``physics``) and its driver node: where it is and has been.
    ``Simulation`` steps it in lockstep with the session's nodes; a grader's judge steps
    one in lockstep with a node in another process (``rosbook.labs.lab05``)."""

    def __init__(self, physics: DiffDriveSim, node: DiffDriveSimNode) -> None:
        self.physics = physics
        self.node = node

    @property
    def now(self) -> float:
        return self.physics.time

    @property
    def trajectory(self) -> Trajectory:
        return self.physics.trajectory


class Simulation(SimulatedRobot):
    """A fresh simulated world on ``/clock``, run in lockstep with the session's nodes.

    Making one resets ``session`` (default: the notebook's) onto simulated time (every
    node is destroyed, time is 0): create the nodes that drive the robot *afterwards*,
    then ``run(seconds)``. ``/clock`` is the session's lockstep clock
    (``session.sim_clock()``), moved once a tick.
    """

    def __init__(
        self,
        world: World | None = None,
        *,
        seed: int = 0,
        tick: float = TICK_S,
        geometry: RobotGeometry | None = None,
        laser: LaserSpec | None = None,
        dt: float = 1.0 / 200.0,
        wheel_noise: float = 0.0,
        scan_noise: float = 0.0,
        cmd_timeout: float = CMD_TIMEOUT_S,
        odom_rate: float = 50.0,
        scan_rate: float = 5.0,
        session: Session | None = None,
    ) -> None:
        steps = tick / dt
        if abs(steps - round(steps)) > 1e-9 or round(steps) < 1:
            raise ValueError(f"tick {tick} s must be a whole number of physics steps of {dt} s")
        self.session = notebook_session(session)
        self._time_source = self.session.sim_clock()
        self.clock = self._time_source.clock
        self.tick = tick
        physics = DiffDriveSim(
            world, geometry, laser, dt=dt, seed=seed, wheel_noise=wheel_noise, scan_noise=scan_noise
        )
        super().__init__(
            physics,
            DiffDriveSimNode(
                physics, cmd_timeout=cmd_timeout, odom_rate=odom_rate, scan_rate=scan_rate
            ),
        )
        self._own = (self.node, self.clock.node)
        self._started = False
        self._ticks = 0
        self.wall_time = 0.0

    def run(
        self,
        seconds: float,
        until: Callable[[], bool] | None = None,
        catch_up_timeout: float = CATCH_UP_TIMEOUT_S,
        wall_timeout: float | None = None,
    ) -> bool:
        """Advance ``seconds`` of simulated time (or until ``until()`` is true).

        Returns whether ``until`` came true (False without one). Raises whatever a
        node's callback raised. ``catch_up_timeout`` and ``wall_timeout`` (seconds of
        wall time, for one tick and for the whole run) only guard against a hang: a node
        that does not follow ``/clock`` or a callback that blocks. Hitting one raises
        ``TimeoutError`` with a message starting "timeout:", never a verdict on speed.
        """
        started = time.perf_counter()
        give_up = math.inf if wall_timeout is None else started + wall_timeout
        # The session's nodes are spun by an executor; the simulator's own node is not:
        # it takes its cmd_vel after the others have had their turn, as Gazebo would in
        # a process of its own, and the executor's wait set stays small.
        nodes = [n for n in self.session.nodes if n not in self._own]
        executor = WakingExecutor()
        for node in nodes:
            executor.add_node(node)
        callbacks = Callbacks(nodes, executor)

        try:
            if not self._started:
                self._started = True
                self._tick(callbacks, catch_up_timeout, advance=False)
            end = self.now + seconds
            while self.now < end - 1e-9:
                if until is not None and until():
                    return True
                if time.perf_counter() > give_up:
                    raise TimeoutError(
                        f"timeout: simulating {seconds:g} s took longer than {wall_timeout:g} s "
                        f"of wall time (stopped at t={self.now:.2f} s); does a callback block?"
                    )
                self._tick(callbacks, catch_up_timeout)
            return until is not None and until()
        finally:
            for node in list(executor.get_nodes()):
                executor.remove_node(node)
            executor.shutdown(timeout_sec=0)
            self.wall_time += time.perf_counter() - started

    def _tick(self, callbacks: Callbacks, catch_up_timeout: float, advance: bool = True) -> None:
        """Physics for one tick, sensors and /clock out, everyone's callbacks, cmd_vel in.

        The first pass takes ``/clock`` (and the sensors); once every node reads the new
        time, the timers that came due run, and the messages the nodes send each other
        meanwhile are taken, pass after pass until nothing is left; then the simulator
        takes ``cmd_vel``. Nothing depends on the wall clock: the run stays the same
        every time.
        """
        if advance:
            self.node.advance(self.tick)
        self.node.publish_sensors(force=not advance)
        spun = self.clock.set(
            to_ns(self.now),
            callbacks.nodes,
            spin=callbacks.spin,
            timeout=catch_up_timeout,
            hint=": was the node created after the Simulation?",
        )
        if not spun:  # every node read this time already: run what is ready all the same
            callbacks.round()
        while timer_due(callbacks.nodes) and callbacks.round():
            pass
        self._ticks += 1
        if self._ticks % EVENTS_EVERY_TICKS == 0:  # QoS events: a full wait of rclpy's
            run_round(callbacks.executor)
        self.node.take_commands()

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall second spent in ``run`` so far."""
        return self.now / self.wall_time if self.wall_time > 0 else math.inf


def main(args: list[str] | None = None) -> None:
    """Run the simulator as a process of its own, on wall time (``python -m rosbook.sim.node``).

    It publishes ``/clock`` at the real-time rate; other processes follow it with
    ``--ros-args -p use_sim_time:=true``.
    """
    rclpy.init(args=args)
    sim = DiffDriveSim()
    node = DiffDriveSimNode(sim)
    clock = LockstepClock(node)  # nobody to wait for: it only publishes
    period = 0.01

    def tick() -> None:
        node.advance(period)
        node.publish_sensors()
        clock.set(to_ns(sim.time))

    node.create_timer(period, tick, clock=RclpyClock(clock_type=ClockType.STEADY_TIME))
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
