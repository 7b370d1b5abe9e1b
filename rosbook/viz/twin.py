"""The digital twin: the lecture robot's URDF in MeshCat, following the 2D simulator.

:mod:`rosbook.sim` moves a flat robot; :mod:`rosbook.viz` draws the URDF robot in 3D.
A :class:`Twin` joins them: each simulated pose places the 3D robot on the floor, and
each wheel angle turns its wheel joint. It works two ways:

- recorded: :meth:`Twin.record` turns a run's frames into a MeshCat animation, and
  :meth:`Twin.scene` into an interactive view for the book or a lab's feedback;
- live: :meth:`Twin.follow` runs a simulation and moves a live MeshCat view (a
  ``viz.live_visualizer()`` in JupyterLab) as the simulated time goes by.

The simulator reports ``base_link`` (``odom``'s child frame), the middle of the axle; the
lecture URDF's ``base_link`` is that same point, so each pose goes to the URDF's
``base_link`` as it is, with no offset. The wheel angles are positive rolling forwards, as
the URDF's wheel joints turn.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import meshcat
import meshcat.geometry as g
import numpy as np
from meshcat.animation import Animation
from nav_msgs.msg import Odometry

from rosbook import robots
from rosbook.robots.urdf import Robot
from rosbook.sim.diff_drive import wheel_speeds
from rosbook.sim.node import Simulation, yaw_of
from rosbook.sim.physics import DiffDriveSim, Pose, RobotGeometry, TwinFrame, World
from rosbook.viz.scene import (
    Bounds,
    RobotView,
    Scene,
    final_transforms,
    planar_pose,
    points_bounds,
)

#: Frames per simulated second of a recorded twin: smooth enough, small enough for a page.
DEFAULT_FPS = 15
#: Height of the walls and boxes drawn around the twin (the 2D world is flat).
OBSTACLE_HEIGHT = 0.25
OBSTACLE_RGB = 0x8A8F98
#: Where the camera looks from by default (metres; MeshCat looks at the origin).
DEFAULT_CAMERA = (-1.5, -3.0, 2.5)


def physics_of(run: Simulation | DiffDriveSim) -> DiffDriveSim:
    """The physics of a ROS-side ``Simulation``, or the physics itself."""
    return run.physics if isinstance(run, Simulation) else run


def joint_positions(frame: TwinFrame) -> dict[str, float]:
    """The URDF joint positions of one frame: both wheels' angles."""
    return {robots.LEFT_WHEEL_JOINT: frame.left_wheel, robots.RIGHT_WHEEL_JOINT: frame.right_wheel}


def current_frame(physics: DiffDriveSim) -> TwinFrame:
    """The simulator's state now, as a twin frame (base_link's pose, wheel angles)."""
    base = physics.pose
    left, right = physics.wheel_angles
    return TwinFrame(physics.time, base.x, base.y, base.yaw, left, right)


def draw_world(
    vis: meshcat.Visualizer, world: World, height: float = OBSTACLE_HEIGHT
) -> Bounds | None:
    """The world's walls and boxes as grey blocks ``height`` tall, under ``/world``.

    Returns the box they fill (None for an empty world), to frame the view around."""
    node = vis["world"]
    node.delete()
    material = g.MeshLambertMaterial(color=OBSTACLE_RGB, opacity=0.6, transparent=True)
    blocks = [("wall", w.corners()) for w in world.all_walls()]
    blocks += [("box", b.corners()) for b in world.boxes]
    for k, (kind, corners) in enumerate(blocks):
        (x0, y0), (x1, y1), (x2, y2) = corners[0], corners[1], corners[2]
        length = math.hypot(x1 - x0, y1 - y0)
        width = math.hypot(x2 - x1, y2 - y1)
        cx = sum(p[0] for p in corners) / 4
        cy = sum(p[1] for p in corners) / 4
        block = node[f"{kind}_{k}"]
        block.set_object(g.Box([length, width, height]), material)
        block.set_transform(planar_pose(cx, cy, math.atan2(y1 - y0, x1 - x0), height / 2))
    corners = [(x, y, z) for _, c in blocks for (x, y) in c for z in (0.0, height)]
    return points_bounds(np.array(corners, dtype=float).reshape(-1, 3))


class Twin:
    """The URDF robot in MeshCat, placed and turned by the simulator's frames.

    ``vis`` is a live MeshCat ``Visualizer`` (from ``viz.live_visualizer()``) or, by
    default, one that records (then :meth:`scene` gives the interactive view).
    ``world`` draws the simulated walls and boxes around the robot; the view frames them
    too unless ``frame_world`` is false (then it frames only where the robot drives).
    """

    def __init__(
        self,
        robot: Robot | None = None,
        vis: meshcat.Visualizer | None = None,
        world: World | None = None,
        camera: Sequence[float] | None = DEFAULT_CAMERA,
        frames: bool = False,
        frame_world: bool = True,
    ) -> None:
        self.robot = robot or robots.diff_drive()
        self.view = RobotView(self.robot, vis=vis, frames=frames, camera=camera)
        #: What the view frames besides the robot's poses: the world, when framed.
        self.framed_world: Bounds | None = None
        if world is not None:
            drawn = draw_world(self.view.vis, world)
            if frame_world:
                self.framed_world = drawn
                self.view.include(drawn)

    @property
    def vis(self) -> meshcat.Visualizer:
        return self.view.vis

    def show(self, frame: TwinFrame) -> None:
        """Put the robot where ``frame`` says: base pose on the floor, wheel angles."""
        self.view.set_base_pose(frame.x, frame.y, frame.yaw)  # first: joints are framed there
        self.view.set_joints(joint_positions(frame))

    def record(
        self, frames: Sequence[TwinFrame], fps: float = DEFAULT_FPS, repetitions: int = 1
    ) -> Animation:
        """A MeshCat animation of ``frames`` (taken every ``1 / fps`` simulated seconds).

        Only what moves is animated: the base's position and heading, and the wheels'
        rotation (a wheel's place on the base is fixed). The view is left at the first
        frame, which is what a viewer shows before the animation plays, and framed on the
        poses the animation passes through (and the world, when framed), not on where the
        robot stood before.
        """
        if not frames:
            raise ValueError("no frames to record")
        self.view.bounds = self.framed_world
        animation = Animation(default_framerate=fps)
        wheels = [self.robot.joint(j).child for j in robots.WHEEL_JOINTS]
        prefix = self.view.prefix
        for k, frame in enumerate(frames):
            poses = self.robot.poses(joint_positions(frame))
            self.view.include_pose(frame.x, frame.y, frame.yaw)
            with animation.at_frame(self.vis, k) as at:
                at[prefix].set_transform(planar_pose(frame.x, frame.y, frame.yaw, self.view.height))
                for link in wheels:
                    rotation = _js_quaternion(poses[link])
                    at[prefix][link].set_property("quaternion", "quaternion", rotation)
        self.show(frames[0])
        self.vis.set_animation(animation, play=True, repetitions=repetitions)
        return animation

    def follow(
        self,
        run: Simulation | DiffDriveSim,
        seconds: float,
        fps: float = 20.0,
        realtime: bool = True,
        until: Callable[[], bool] | None = None,
    ) -> bool:
        """Run the simulation ``seconds`` more, moving the twin ``fps`` times a second.

        With ``realtime`` the loop waits so that a live view moves at the speed of the
        simulated robot (the simulator alone is many times faster). Returns whether
        ``until()`` came true (a ``Simulation`` checks it every tick).
        """
        physics = physics_of(run)
        period = 1.0 / fps
        if isinstance(run, Simulation):
            period = max(1, round(period / run.tick)) * run.tick
        end = physics.time + seconds
        self.show(current_frame(physics))
        started, simulated_start = time.perf_counter(), physics.time
        while physics.time < end - 1e-9:
            chunk = min(period, end - physics.time)
            if isinstance(run, Simulation):
                done = run.run(chunk, until=until)
            else:
                run.run(chunk)
                done = until is not None and until()
            self.show(current_frame(physics))
            if done:
                return True
            if realtime:
                ahead = (physics.time - simulated_start) - (time.perf_counter() - started)
                if ahead > 0:
                    time.sleep(ahead)
        return False

    def scene(self, height: int = 400) -> Scene:
        """What was recorded, as an interactive view (needs a recording twin)."""
        return self.view.scene(height=height)


def record(
    run: Simulation | DiffDriveSim,
    fps: float = DEFAULT_FPS,
    world: World | None = None,
    height: int = 400,
    camera: Sequence[float] | None = DEFAULT_CAMERA,
    repetitions: int = 1000,
    last: float | None = None,
) -> Scene:
    """A run's recorded twin: its world and the URDF robot replaying the drive.

    ``world`` (the walls and boxes drawn) defaults to the run's. The drive plays in a
    loop (``repetitions`` times), so a reader who scrolls to it late still sees it move.
    The last frame is the run's end, so the twin stops where the simulator stopped.
    ``last``: replay only the run's last seconds, framed on where the robot drives then
    (a world too big to show the robot large enough, on a phone, whole).
    """
    physics = physics_of(run)
    frames = physics.twin_frames(1.0 / fps)
    end = current_frame(physics)
    if not frames or frames[-1].t < end.t - 1e-9:
        frames.append(end)  # end exactly where the run ended
    if last is not None:
        frames = [f for f in frames if f.t >= end.t - last - 1e-9]
    twin = Twin(
        world=world if world is not None else physics.world,
        camera=camera,
        frame_world=last is None,
    )
    twin.record(frames, fps=fps, repetitions=repetitions)
    return twin.scene(height=height)


def odometry_frames(
    odometry: Iterable[Odometry],
    fps: float = DEFAULT_FPS,
    geometry: RobotGeometry | None = None,
) -> list[TwinFrame]:
    """Twin frames from ``odom`` messages (a bag's, played back or read), ``fps`` per
    second of their stamps.

    Each frame's pose is a message's (its ``base_link`` is the URDF's); the wheel angles,
    which ``Odometry`` does not carry, are integrated from each message's twist through
    the kinematics. The last message always gives the last
    frame, so the twin ends where the recording ended.
    """
    geometry = geometry or RobotGeometry()
    r, sep = geometry.wheel_radius, geometry.wheel_separation
    frames: list[TwinFrame] = []
    left = right = 0.0
    last_t: float | None = None
    pending: TwinFrame | None = None
    for msg in odometry:
        t = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        if last_t is not None:
            w_left, w_right = wheel_speeds(
                msg.twist.twist.linear.x, msg.twist.twist.angular.z, r, sep
            )
            left, right = left + w_left * (t - last_t), right + w_right * (t - last_t)
        last_t = t
        p, yaw = msg.pose.pose.position, yaw_of(msg)
        pending = TwinFrame(t, p.x, p.y, yaw, left, right)
        if not frames or t >= frames[0].t + len(frames) / fps - 1e-9:
            frames.append(pending)
            pending = None
    if pending is not None:
        frames.append(pending)
    return frames


# -- reading a recorded twin back (for the book's and the tests' checks) ----------------


def _js_quaternion(matrix: np.ndarray) -> list[float]:
    """A rotation as three.js stores it: (x, y, z, w)."""
    from meshcat.animation import js_quaternion

    return [float(v) for v in js_quaternion(matrix)]


def final_poses(commands: Iterable[Mapping[str, Any]], prefix: str) -> dict[str, np.ndarray]:
    """World pose of every link of robot ``prefix`` at the end of a recorded animation.

    Read from the MeshCat commands themselves (``Scene.commands``, or those decoded from a
    built page): each link's last transform (``scene.final_transforms``: its last
    ``set_transform``, overridden by the last key of its animation tracks), placed by the
    robot's animated base transform.
    """
    root = f"/meshcat/{prefix}"
    local = final_transforms(commands)
    if root not in local:
        raise ValueError(f"no robot {prefix!r} in these commands")
    base = local[root]
    links = {p.rsplit("/", 1)[1] for p in local if p.startswith(root + "/") and p.count("/") == 3}
    return {link: base @ local[f"{root}/{link}"] for link in sorted(links)}


def axle_pose(poses: Mapping[str, np.ndarray]) -> Pose:
    """The twin's odometry pose: the middle of its two wheels and its heading.

    That is the point the simulator (and ``odom``) reports, so it must match the
    simulator's final pose when the twin followed it.
    """
    left, right = poses["left_wheel"], poses["right_wheel"]
    middle = (left[:3, 3] + right[:3, 3]) / 2
    base = poses["base_link"]
    return Pose(float(middle[0]), float(middle[1]), math.atan2(base[1, 0], base[0, 0]))
