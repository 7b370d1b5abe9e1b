"""tf2's frame tree in MeshCat: every frame a ``Buffer`` knows, where tf2 puts it.

RViz's TF display, for this book: each frame the buffer knows is a triad (x red, y green,
z blue) at its pose in a fixed frame (``odom`` by default), asked of the buffer itself with
``lookup_transform``, and a thin line joins it to its parent, so the tree shows. A frame
that cannot be looked up at that time (not yet heard, too old, in another tree) is
hidden, not an error. Optionally the URDF robot stands on its frame (``base_link``).

One drawing function (:meth:`FrameTree.state`: what the view shows at a time), two uses:

- live: :meth:`FrameTree.follow` (or :func:`live`) redraws on a timer of a node, on that
  node's clock (simulated time when the session runs on the simulator), into a
  ``viz.live_visualizer()`` in JupyterLab;
- recorded: :meth:`FrameTree.record` (or :func:`record`) samples the buffer at the times
  of a run into a MeshCat animation, and :meth:`FrameTree.scene` gives the interactive
  view a page embeds.

The fixed frame is drawn where the robot's root link stands at rest: ``odom`` → ``base_link``
is flat (z = 0) and ``base_link`` is the middle of the wheel axle, so ``odom``'s origin is
the axle's height above MeshCat's floor grid (:meth:`RobotView.placed`).
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import meshcat
import meshcat.geometry as g
import numpy as np
from geometry_msgs.msg import TransformStamped
from meshcat.animation import Animation, AnimationFrameVisualizer
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.time import Time
from rclpy.timer import Timer

from rosbook.robots.urdf import Robot
from rosbook.runtime.transforms import Buffer, TransformException, TransformListener
from rosbook.viz.scene import (
    Bounds,
    RobotView,
    Scene,
    final_properties,
    final_transforms,
    framing,
    points_bounds,
    recording_visualizer,
    rotation_of,
    union,
)
from rosbook.viz.twin import DEFAULT_CAMERA, DEFAULT_FPS

#: Where the tree is drawn: ``/meshcat/tf/<frame>`` (the frame's pose, its triad and the
#: line to its parent below it).
PREFIX = "tf"
#: Length of a frame's triad's axes (metres).
TRIAD_SCALE = 0.25
#: The line from a frame to its parent (RViz draws it from child to parent too).
LINK_RGB = 0xC2185B
#: How often a live view redraws (seconds of its node's clock).
LIVE_PERIOD = 0.1

#: One line of ``Buffer.all_frames_as_string()`` (tf2's words).
_FRAME_LINE = re.compile(r"^Frame (\S+) exists with parent (\S+)\.$", re.M)

#: What the view shows: (scene-tree path, property) -> value; property ``transform`` (a
#: 4x4 array, the path's pose in its parent node), ``visible`` or ``scale``.
State = dict[tuple[str, str], Any]


def frame_parents(buffer: Buffer) -> dict[str, str | None]:
    """Every frame ``buffer`` knows and its parent (``None``: a root, e.g. ``odom``),
    read from tf2's own listing, ``all_frames_as_string()``."""
    parents: dict[str, str | None] = {}
    for child, parent in _FRAME_LINE.findall(buffer.all_frames_as_string()):
        parents[child] = parent
        parents.setdefault(parent, None)
    return parents


def node_name(frame: str) -> str:
    """A frame's name as one scene-tree name (tf2 allows ``/`` inside: ``robot1/base_link``)."""
    return frame.replace("%", "%25").replace("/", "%2F")


def frame_name(node: str) -> str:
    """The frame a scene-tree name stands for (the inverse of :func:`node_name`)."""
    return node.replace("%2F", "/").replace("%25", "%")


def transform_matrix(t: TransformStamped) -> np.ndarray:
    """A ``TransformStamped`` as a 4x4 matrix (points in the child frame to the parent)."""
    r, p = t.transform.rotation, t.transform.translation
    matrix = np.eye(4)
    matrix[:3, :3] = rotation_of((r.x, r.y, r.z, r.w))
    matrix[:3, 3] = p.x, p.y, p.z
    return matrix


def _towards(direction: np.ndarray) -> np.ndarray:
    """A rotation (3x3) that turns the x axis onto unit vector ``direction``."""
    x = np.array([1.0, 0.0, 0.0])
    axis = np.cross(x, direction)
    s, c = float(np.linalg.norm(axis)), float(np.dot(x, direction))
    if s < 1e-12:
        return np.eye(3) if c > 0 else np.diag([-1.0, -1.0, 1.0])
    k = axis / s
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * skew + (1 - c) * skew @ skew


class FrameTree:
    """tf2's frames in a MeshCat view, at their poses in ``fixed_frame``.

    ``vis``: a live ``Visualizer`` or, by default, the robot's or one that records.
    ``robot``: a URDF robot drawn with its root link on frame ``robot_frame`` (the
    book's scenes need a robot body in view). The scene tree is
    ``/meshcat/<prefix>/<frame>`` (the frame's pose), with ``triad`` and ``to_parent``
    (a unit line along x, turned and stretched to reach the parent's origin) below it.
    """

    def __init__(
        self,
        fixed_frame: str = "odom",
        vis: meshcat.Visualizer | None = None,
        robot: Robot | None = None,
        robot_frame: str = "base_link",
        camera: Sequence[float] | None = DEFAULT_CAMERA,
        scale: float = TRIAD_SCALE,
        prefix: str = PREFIX,
    ) -> None:
        self.fixed_frame = fixed_frame
        self.robot_frame = robot_frame
        self.vis = vis if vis is not None else recording_visualizer()
        self.robot = None if robot is None else RobotView(robot, vis=self.vis, camera=camera)
        self.camera = camera
        self.scale = scale
        self.prefix = prefix
        #: The transforms last drawn, by frame (each as ``lookup_transform`` gave it).
        self.drawn: dict[str, TransformStamped] = {}
        #: How many times the view was drawn (live) or sampled (recorded).
        self.draws = 0
        #: The box the frames' origins have been in (scene coordinates): the framing.
        self.bounds: Bounds | None = None
        self._lift = np.eye(4)
        self._lift[2, 3] = self.robot.height if self.robot is not None else 0.0
        #: The listener :func:`live` made for its own buffer, if it did.
        self.listener: TransformListener | None = None
        self._objects: set[str] = set()
        self._timer: tuple[Node, Timer] | None = None
        self.vis[prefix].delete()
        self.vis[prefix].set_transform(self._lift)

    def path(self, frame: str, *below: str) -> str:
        """The scene-tree path of ``frame`` (or of a node below it)."""
        return "/".join([self.prefix, node_name(frame), *below])

    # -- the one drawing function -----------------------------------------------------

    def state(self, buffer: Buffer, time: Time) -> State:
        """What the view shows at ``time`` (``Time()``: tf2's latest for each frame).

        Each frame the buffer knows is placed where ``lookup_transform(fixed_frame,
        frame, time)`` says; one that cannot be looked up is hidden, and so is one drawn
        before that the buffer has forgotten (its clock jumped back). The line to a
        parent shows only where both ends are known.
        """
        parents = frame_parents(buffer)
        for path in sorted(self._objects):
            parents.setdefault(frame_name(path.split("/")[1]), None)
        found: dict[str, TransformStamped] = {}
        for frame in parents:
            try:
                found[frame] = buffer.lookup_transform(self.fixed_frame, frame, time)
            except TransformException:
                continue
        poses = {frame: transform_matrix(t) for frame, t in found.items()}
        state: State = {}
        for frame, parent in parents.items():
            pose = poses.get(frame)
            state[self.path(frame), "visible"] = pose is not None
            if pose is None:
                continue
            state[self.path(frame), "transform"] = pose
            link = self.path(frame, "to_parent")
            reach = None if parent not in poses else np.linalg.solve(pose, poses[parent])[:3, 3]
            length = 0.0 if reach is None else float(np.linalg.norm(reach))
            state[link, "visible"] = length > 1e-9
            if length > 1e-9:
                turn = np.eye(4)
                turn[:3, :3] = _towards(reach / length)
                state[link, "transform"] = turn
                state[link, "scale"] = [length, 1.0, 1.0]
        if self.robot is not None and self.robot_frame in poses:
            state[self.robot.prefix, "transform"] = self.robot.placed(poses[self.robot_frame])
        self.drawn = found
        self.draws += 1
        return state

    def _frame(self, state: State) -> None:
        """Make the objects of frames not drawn before; grow the framing by ``state``."""
        for (path, prop), value in state.items():
            if prop != "transform":
                continue
            if self.robot is not None and path == self.robot.prefix:
                self.robot.include_base(value)
                continue
            if path.count("/") != 1:
                continue  # a line to a parent
            if path not in self._objects:
                self._objects.add(path)
                self.vis[path]["triad"].set_object(g.triad(self.scale))
                line = g.PointsGeometry(np.array([[0.0, 1.0], [0.0, 0.0], [0.0, 0.0]]))
                self.vis[path]["to_parent"].set_object(
                    g.Line(line, g.LineBasicMaterial(color=LINK_RGB))
                )
            origin = (self._lift @ value)[:3, 3]
            self.bounds = union(self.bounds, points_bounds(origin.reshape(1, 3)))

    def _show(self, state: State) -> None:
        """Send ``state`` to the view."""
        self._frame(state)
        for (path, prop), value in state.items():
            if prop == "transform":
                self.vis[path].set_transform(value)
            else:
                self.vis[path].set_property(prop, value)

    # -- live -------------------------------------------------------------------------

    def draw(self, buffer: Buffer, time: Time | None = None) -> dict[str, TransformStamped]:
        """Draw the tree now, at ``time`` (default ``Time()``: the latest); returns the
        transforms drawn, by frame."""
        self._show(self.state(buffer, Time() if time is None else time))
        return self.drawn

    def follow(
        self, node: Node, buffer: Buffer, period: float = LIVE_PERIOD, realtime: bool = True
    ) -> Timer:
        """Redraw every ``period`` seconds of ``node``'s clock, on a timer of ``node``
        (its executor must spin it, as the session does). :meth:`stop` ends it.

        With ``realtime``, a redraw that comes sooner on the wall clock than on the
        node's waits for the difference, so that a simulation many times faster than
        real time moves the view at the robot's speed (as ``Twin.follow`` does); on wall
        time there is nothing to wait for.
        """
        self.stop()
        last: list[tuple[int, float]] = []

        def redraw() -> None:
            self.draw(buffer)
            if not realtime:
                return
            now, wall = node.get_clock().now().nanoseconds, time.perf_counter()
            if last:
                ahead = (now - last[0][0]) / 1e9 - (wall - last[0][1])
                if 0 < ahead <= period:  # not across a jump of the clock
                    time.sleep(ahead)
            last[:] = [(now, time.perf_counter())]

        timer = node.create_timer(period, redraw)
        self._timer = (node, timer)
        return timer

    def stop(self) -> None:
        """Stop redrawing (destroys the timer :meth:`follow` made)."""
        if self._timer is not None:
            node, timer = self._timer
            node.destroy_timer(timer)
            self._timer = None

    # -- recorded ---------------------------------------------------------------------

    def record(
        self,
        buffer: Buffer,
        times: Sequence[Time],
        fps: float = DEFAULT_FPS,
        repetitions: int = 1000,
    ) -> Animation:
        """A MeshCat animation of the tree at ``times``, one frame each, played ``fps``
        frames a second; the view is left at the first frame (what shows before it plays).

        What does not change over the run is set once instead of animated.
        """
        if not times:
            raise ValueError("no times to record")
        states = [self.state(buffer, t) for t in times]
        keys = list(dict.fromkeys(k for state in states for k in state))
        animated = {k for k in keys if not _constant([s[k] for s in states if k in s])}
        for state in states:
            self._frame(state)
        first = {k: next(s[k] for s in states if k in s) for k in keys}
        self._show(first)
        animation = Animation(default_framerate=fps)
        for index, state in enumerate(states):
            with animation.at_frame(self.vis, index) as at:
                for key in [k for k in keys if k in animated and k in state]:
                    _animate(at, key, state[key])
        self.vis.set_animation(animation, play=True, repetitions=repetitions)
        return animation

    def scene(self, height: int = 400) -> Scene:
        """What was recorded, as an interactive view, framed on the frames and the robot."""
        window = self.vis.window
        commands = getattr(window, "commands", None)
        if commands is None:
            raise TypeError("scene() needs a recording view: FrameTree() without vis")
        bounds = union(self.bounds, self.robot.bounds if self.robot is not None else None)
        return Scene(
            commands,
            height=height,
            frame=framing(bounds, self.camera),
            description=self.describe(),
        )

    def describe(self) -> str:
        """The scene in words (its still picture's alt text)."""
        frames = sorted(frame_name(p.split("/")[1]) for p in self._objects)
        robot = (
            f"the robot {self.robot.prefix} standing on {self.robot_frame}, and "
            if self.robot is not None
            else ""
        )
        commands = getattr(self.vis.window, "commands", [])
        moving = any(c["type"] == "set_animation" for c in commands)
        return (
            f"{'Animated 3D' if moving else '3D'} view of {robot}tf2's frames "
            f"{', '.join(frames)} in {self.fixed_frame}: each a triad (x red, y green, "
            "z blue) joined to its parent by a line, on MeshCat's floor grid."
        )


def _constant(values: Sequence[Any]) -> bool:
    """Whether a property keeps one value (to rounding: a static link's line)."""
    first = np.asarray(values[0], dtype=float)
    return all(np.allclose(np.asarray(v, dtype=float), first, rtol=0, atol=1e-9) for v in values)


def _animate(at: AnimationFrameVisualizer, key: tuple[str, str], value: Any) -> None:
    """One key of an animation frame: a pose, a visibility or a scale."""
    path, prop = key
    node = at[path]
    if prop == "transform":
        node.set_transform(value)
    elif prop == "visible":
        node.set_property("visible", "boolean", bool(value))
    else:
        node.set_property(prop, "vector3", [float(v) for v in value])


def sample_times(
    buffer: Buffer, fixed_frame: str, seconds: float, fps: float = DEFAULT_FPS
) -> list[Time]:
    """The last ``seconds`` of what ``buffer`` holds, ``fps`` times a second, ending at
    the latest time every frame it knows can be looked up in ``fixed_frame``."""
    stamps = []
    for frame in frame_parents(buffer):
        try:
            stamp = buffer.lookup_transform(fixed_frame, frame, Time()).header.stamp
        except TransformException:
            continue
        if (ns := Time.from_msg(stamp).nanoseconds) > 0:  # 0: static all the way
            stamps.append(ns)
    if not stamps:
        raise ValueError(f"no frame of this buffer moves in {fixed_frame!r}: nothing to record")
    end = Time(nanoseconds=min(stamps))
    count = math.floor(seconds * fps + 1e-9)
    times = [end - Duration(nanoseconds=round((count - k) * 1e9 / fps)) for k in range(count)]
    return [t for t in times if t.nanoseconds >= 0] + [end]


def record(
    buffer: Buffer,
    fixed_frame: str = "odom",
    seconds: float = 9.0,
    robot: Robot | None = None,
    fps: float = DEFAULT_FPS,
    height: int = 400,
    camera: Sequence[float] | None = DEFAULT_CAMERA,
) -> Scene:
    """The last ``seconds`` of ``buffer``'s frames (it keeps 10 s by default), recorded
    as a looping 3D scene in ``fixed_frame``, with ``robot`` on ``base_link``."""
    tree = FrameTree(fixed_frame, robot=robot, camera=camera)
    tree.record(buffer, sample_times(buffer, fixed_frame, seconds, fps), fps=fps)
    return tree.scene(height=height)


def live(
    node: Node,
    vis: meshcat.Visualizer,
    fixed_frame: str = "odom",
    buffer: Buffer | None = None,
    robot: Robot | None = None,
    period: float = LIVE_PERIOD,
    realtime: bool = True,
) -> FrameTree:
    """A live view of the tree, redrawn every ``period`` seconds of ``node``'s clock, at
    the pace of the wall clock with ``realtime`` (see :meth:`FrameTree.follow`).

    Without ``buffer``, ``node`` gets a ``Buffer`` and a ``TransformListener`` of its own.
    """
    tree = FrameTree(fixed_frame, vis=vis, robot=robot)
    if buffer is None:
        buffer = Buffer(node=node)
        tree.listener = TransformListener(buffer, node)
    tree.follow(node, buffer, period, realtime)
    return tree


def final_frames(
    commands: Iterable[Mapping[str, Any]], prefix: str = PREFIX
) -> dict[str, np.ndarray | None]:
    """Each frame's pose in the scene at the end of a recorded tree (``Scene.commands``),
    ``None`` where it is hidden then; in the fixed frame, as drawn (the lift included)."""
    local = final_transforms(commands)
    visible = final_properties(commands, "visible")
    root = f"/meshcat/{prefix}"
    lift = local.get(root, np.eye(4))
    poses: dict[str, np.ndarray | None] = {}
    for path in visible:
        parts = path.split("/")
        if len(parts) == 4 and path.startswith(root + "/"):
            poses[frame_name(parts[3])] = lift @ local[path] if visible[path] else None
    return poses
