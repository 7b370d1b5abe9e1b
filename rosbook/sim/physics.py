"""A 2D differential-drive robot in Pymunk: the book's stand-in for Gazebo.

The robot is the lecture's: a 0.6 m x 0.3 m base, two driven wheels of radius 0.04 m
on one axle and a caster at the back. In the lecture's URDF ``base_link`` is the middle
of the axle, the wheel joints sit at ``xyz="0 0.2 0"`` and ``0 -0.2 0``, so the wheels are
0.4 m apart, and the box's centre is 0.2 m behind the axle.

The simulator's reference point (``base_link``, the pose ``odom`` reports) is that same
frame, the middle of the axle, as for every differential-drive base in ROS: turning in
place turns about it, and a constant (v, w) moves it on a circle of radius v / w.

Each physics step (a fixed ``dt`` of 5 ms by default, never the wall clock) turns the
command into wheel speeds through :mod:`rosbook.sim.diff_drive`, limits them like a motor
would, adds seeded wheel noise if asked, and moves the body along the exact arc for
that step. The wheels do not slip on the floor, so free driving matches the closed
form; the robot is a kinematic Pymunk body, and Pymunk's collision detection refuses a
move into a wall or an obstacle (the wheels then spin in place) and reports the touch
as a collision. The lidar casts its rays against the same polygons. Same world, same
seed, same commands: the same path, to the bit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pymunk

from rosbook.sim.diff_drive import arc_step, body_twist, wheel_speeds, wrap_angle

ROBOT_CATEGORY = 0b01
WORLD_CATEGORY = 0b10
#: Touches closer together than this (seconds) count as one collision.
TOUCH_GAP_S = 0.25


@dataclass(frozen=True)
class RobotGeometry:
    """The lecture robot's dimensions (metres, kilograms)."""

    length: float = 0.6
    width: float = 0.3
    wheel_radius: float = 0.04
    wheel_width: float = 0.05
    #: Wheels at y = +-0.2 m in the lecture's URDF.
    wheel_separation: float = 0.4
    #: The base box's centre along x in base_link (the axle's middle): 0.2 m behind it,
    #: where the URDF's base_link visual has its ``<origin>``.
    box_x: float = -0.2
    #: The caster's centre along x in base_link, behind the box's centre.
    caster_x: float = -0.42
    caster_radius: float = 0.03
    mass: float = 5.0
    #: Motor limit: wheel speeds are scaled down together beyond it (keeps the curvature).
    max_wheel_speed: float = 30.0

    def footprint(self) -> list[tuple[float, float]]:
        """Corners of the base, in the base_link frame (axle middle at the origin)."""
        back = self.box_x - self.length / 2
        front = self.box_x + self.length / 2
        half = self.width / 2
        return [(back, -half), (front, -half), (front, half), (back, half)]

    def wheel_box(self, side: int) -> list[tuple[float, float]]:
        """Corners of a wheel seen from above (side +1 left, -1 right)."""
        y = side * self.wheel_separation / 2
        r, h = self.wheel_radius, self.wheel_width / 2
        return [(-r, y - h), (r, y - h), (r, y + h), (-r, y + h)]


@dataclass(frozen=True)
class LaserSpec:
    """A planar lidar at the axle middle, like a 360-degree LDS on a small robot."""

    count: int = 360
    angle_min: float = -math.pi
    range_min: float = 0.12
    range_max: float = 8.0
    #: Where it is mounted along the robot's x axis, from base_link.
    offset: float = 0.0

    @property
    def angle_increment(self) -> float:
        return 2.0 * math.pi / self.count

    @property
    def angle_max(self) -> float:
        return self.angle_min + (self.count - 1) * self.angle_increment

    def angles(self) -> np.ndarray:
        return self.angle_min + self.angle_increment * np.arange(self.count)


@dataclass(frozen=True)
class Wall:
    """A straight wall from ``start`` to ``end`` (metres), ``thickness`` thick."""

    start: tuple[float, float]
    end: tuple[float, float]
    thickness: float = 0.05

    def corners(self) -> list[tuple[float, float]]:
        """The wall as a rectangle: the segment thickened by half the thickness each side."""
        (x0, y0), (x1, y1) = self.start, self.end
        length = math.hypot(x1 - x0, y1 - y0) or 1.0
        nx = -(y1 - y0) / length * self.thickness / 2
        ny = (x1 - x0) / length * self.thickness / 2
        return [(x0 + nx, y0 + ny), (x1 + nx, y1 + ny), (x1 - nx, y1 - ny), (x0 - nx, y0 - ny)]


@dataclass(frozen=True)
class Box:
    """A rectangular obstacle centred at ``center``, ``size`` = (x extent, y extent)."""

    center: tuple[float, float]
    size: tuple[float, float]
    angle: float = 0.0

    def corners(self) -> list[tuple[float, float]]:
        c, s = math.cos(self.angle), math.sin(self.angle)
        hx, hy = self.size[0] / 2, self.size[1] / 2
        return [
            (self.center[0] + c * px - s * py, self.center[1] + s * px + c * py)
            for px, py in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))
        ]


@dataclass(frozen=True)
class World:
    """A walled arena ``(xmin, ymin, xmax, ymax)`` (or none), walls, boxes, a start pose."""

    arena: tuple[float, float, float, float] | None = (-2.5, -2.5, 2.5, 2.5)
    walls: tuple[Wall, ...] = ()
    boxes: tuple[Box, ...] = ()
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)

    @classmethod
    def from_dict(cls, spec: Mapping[str, Any]) -> World:
        """A world from plain data, e.g. ``{"arena": [-2, -2, 2, 2], "boxes": [...]}``."""
        arena = spec.get("arena", cls.arena)
        return cls(
            arena=tuple(arena) if arena is not None else None,  # type: ignore[arg-type]
            walls=tuple(
                Wall(tuple(w["start"]), tuple(w["end"]), w.get("thickness", 0.05))  # type: ignore[arg-type]
                for w in spec.get("walls", ())
            ),
            boxes=tuple(
                Box(tuple(b["center"]), tuple(b["size"]), b.get("angle", 0.0))  # type: ignore[arg-type]
                for b in spec.get("boxes", ())
            ),
            start=tuple(spec.get("start", (0.0, 0.0, 0.0))),  # type: ignore[arg-type]
        )

    def all_walls(self) -> list[Wall]:
        """The arena's four walls (inner faces on its bounds) and the extra walls."""
        walls = list(self.walls)
        if self.arena is not None:
            x0, y0, x1, y1 = self.arena
            t = 0.1
            h = t / 2
            walls += [
                Wall((x0 - t, y0 - h), (x1 + t, y0 - h), t),
                Wall((x0 - t, y1 + h), (x1 + t, y1 + h), t),
                Wall((x0 - h, y0 - t), (x0 - h, y1 + t), t),
                Wall((x1 + h, y0 - t), (x1 + h, y1 + t), t),
            ]
        return walls


@dataclass(frozen=True)
class Pose:
    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class TwinFrame:
    """One frame of a recorded run: base_link's pose and the wheels' joint angles."""

    t: float
    x: float
    y: float
    yaw: float
    left_wheel: float
    right_wheel: float


@dataclass(frozen=True)
class Collision:
    """The robot touched something at time ``t`` (first contact of a touch)."""

    t: float
    x: float
    y: float


@dataclass
class Trajectory:
    """Every physics step's time, pose and wheel angles: the data of the digital twin."""

    t: list[float] = field(default_factory=list)
    x: list[float] = field(default_factory=list)
    y: list[float] = field(default_factory=list)
    yaw: list[float] = field(default_factory=list)
    left: list[float] = field(default_factory=list)
    right: list[float] = field(default_factory=list)

    def append(self, t: float, pose: Pose, left: float, right: float) -> None:
        self.t.append(t)
        self.x.append(pose.x)
        self.y.append(pose.y)
        self.yaw.append(pose.yaw)
        self.left.append(left)
        self.right.append(right)

    def __len__(self) -> int:
        return len(self.t)

    def as_array(self) -> np.ndarray:
        """Columns t, x, y, yaw, left wheel angle, right wheel angle."""
        return np.column_stack([self.t, self.x, self.y, self.yaw, self.left, self.right])

    def sample(self, period: float) -> Trajectory:
        """Every ``period`` seconds (for animations and the MeshCat twin)."""
        out = Trajectory()
        next_t = self.t[0] if self.t else 0.0
        for i, t in enumerate(self.t):
            if t >= next_t - 1e-9:
                out.append(t, Pose(self.x[i], self.y[i], self.yaw[i]), self.left[i], self.right[i])
                next_t += period
        return out

    def since(self, t0: float) -> Trajectory:
        """The part from time ``t0`` on."""
        out = Trajectory()
        for i, t in enumerate(self.t):
            if t >= t0 - 1e-9:
                out.append(t, Pose(self.x[i], self.y[i], self.yaw[i]), self.left[i], self.right[i])
        return out


class DiffDriveSim:
    """The robot in its world, stepped by a fixed ``dt``; commands are (v, w) or wheel speeds."""

    def __init__(
        self,
        world: World | None = None,
        geometry: RobotGeometry | None = None,
        laser: LaserSpec | None = None,
        *,
        dt: float = 1.0 / 200.0,
        seed: int = 0,
        wheel_noise: float = 0.0,
        scan_noise: float = 0.0,
    ) -> None:
        self.world = world or World()
        self.geometry = geometry or RobotGeometry()
        self.laser = laser or LaserSpec()
        self.dt = dt
        self.wheel_noise = wheel_noise
        self.scan_noise = scan_noise
        self.rng = np.random.default_rng(seed)
        self.steps = 0
        self.collisions: list[Collision] = []
        self.trajectory = Trajectory()
        self._wheel_cmd = (0.0, 0.0)
        self._wheel_angles = [0.0, 0.0]
        self._twist = (0.0, 0.0)
        self._touching = False
        self._released_at = -math.inf
        self._build_space()
        self.trajectory.append(0.0, self.pose, 0.0, 0.0)

    # -- world ------------------------------------------------------------------
    def _build_space(self) -> None:
        self.space = pymunk.Space()
        g = self.geometry
        # A kinematic body whose origin is the axle middle: each step places it on the
        # kinematics' arc; Pymunk's collision detection says whether that pose is free.
        self.body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        x, y, yaw = self.world.start
        self.body.position = (x, y)
        self.body.angle = yaw
        robot_filter = pymunk.ShapeFilter(categories=ROBOT_CATEGORY, mask=WORLD_CATEGORY)
        self.robot_shapes: list[pymunk.Shape] = [
            pymunk.Poly(self.body, g.footprint()),
            pymunk.Poly(self.body, g.wheel_box(+1)),
            pymunk.Poly(self.body, g.wheel_box(-1)),
            pymunk.Circle(self.body, g.caster_radius, (g.caster_x, 0.0)),
        ]
        for shape in self.robot_shapes:
            shape.filter = robot_filter
        self.space.add(self.body, *self.robot_shapes)
        static = self.space.static_body
        world_filter = pymunk.ShapeFilter(categories=WORLD_CATEGORY)
        obstacles = [pymunk.Poly(static, w.corners()) for w in self.world.all_walls()]
        obstacles += [pymunk.Poly(static, b.corners()) for b in self.world.boxes]
        for shape in obstacles:
            shape.filter = world_filter
        self.space.add(*obstacles)
        self._ray_filter = pymunk.ShapeFilter(mask=WORLD_CATEGORY)
        self._edges = _world_edges(self.world)
        corners = g.footprint() + g.wheel_box(+1) + g.wheel_box(-1)
        self._reach = 0.01 + max(math.hypot(px - g.box_x, py) for px, py in corners)
        if self._overlap() is not None:
            raise ValueError(f"the start pose {self.world.start} overlaps a wall or an obstacle")

    def _overlap(self) -> tuple[float, float] | None:
        """A contact point if the robot at its current pose overlaps the world."""
        centre = self.body.local_to_world((self.geometry.box_x, 0.0))
        if self.space.point_query_nearest(centre, self._reach, self._ray_filter) is None:
            return None  # nothing within the robot's bounding circle: free
        self.space.reindex_shapes_for_body(self.body)
        for shape in self.robot_shapes:
            for hit in self.space.shape_query(shape):
                points = hit.contact_point_set.points
                if points:
                    return float(points[0].point_a.x), float(points[0].point_a.y)
        return None

    def _move_to(self, x: float, y: float, angle: float) -> tuple[float, float] | None:
        """Place the robot if that pose is free; otherwise stay and return the contact."""
        old_position, old_angle = self.body.position, self.body.angle
        self.body.position = (x, y)
        self.body.angle = angle
        contact = self._overlap()
        if contact is not None:
            self.body.position = old_position
            self.body.angle = old_angle
        return contact

    # -- state ------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated seconds since the start (an integer count of ``dt`` steps)."""
        return self.steps * self.dt

    @property
    def pose(self) -> Pose:
        """base_link (axle middle) in the world frame; yaw in (-pi, pi]."""
        p = self.body.position
        return Pose(float(p.x), float(p.y), wrap_angle(float(self.body.angle)))

    @property
    def twist(self) -> tuple[float, float]:
        """(v, w) the body actually moved with during the last step."""
        return self._twist

    @property
    def wheel_angles(self) -> tuple[float, float]:
        """(left, right) wheel angles in radians, accumulated (not wrapped)."""
        return self._wheel_angles[0], self._wheel_angles[1]

    @property
    def in_contact(self) -> bool:
        """Whether the last attempted move ran into something."""
        return self._touching

    def twin_frames(self, period: float = 0.05) -> list[TwinFrame]:
        """The run every ``period`` s as the URDF model needs it (a digital twin's input).

        Each frame carries the pose of ``base_link`` (the URDF's and the simulator's are
        the same frame, the axle's middle) and both wheel angles (radians, positive
        rolling forwards).
        """
        sampled = self.trajectory.sample(period)
        return [
            TwinFrame(
                t, sampled.x[i], sampled.y[i], sampled.yaw[i], sampled.left[i], sampled.right[i]
            )
            for i, t in enumerate(sampled.t)
        ]

    # -- commands -----------------------------------------------------------------
    def command(self, v: float, w: float) -> None:
        """Drive at (v, w) from now on: becomes wheel speeds via the kinematics."""
        g = self.geometry
        self.command_wheels(*wheel_speeds(v, w, g.wheel_radius, g.wheel_separation))

    def command_wheels(self, left: float, right: float) -> None:
        """Turn the wheels at ``left``/``right`` rad/s, scaled into the motor limit."""
        biggest = max(abs(left), abs(right))
        limit = self.geometry.max_wheel_speed
        if biggest > limit:
            left, right = left * limit / biggest, right * limit / biggest
        self._wheel_cmd = (left, right)

    @property
    def wheel_command(self) -> tuple[float, float]:
        return self._wheel_cmd

    # -- stepping -----------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Advance ``n`` fixed steps of ``dt``.

        Each step moves along the exact arc of the wheels' (v, w). A move that would
        run into a wall or an obstacle is not made (the wheels slip, as a real robot's
        do against a wall); turning on the spot is still tried, so a robot can turn
        away from what it touches. The start of each touch is a ``Collision``.
        """
        g = self.geometry
        dt = self.dt
        for _ in range(n):
            left, right = self._wheel_cmd
            if self.wheel_noise > 0.0 and (left or right):
                noise = self.rng.normal(0.0, self.wheel_noise, 2)
                left, right = left * (1.0 + noise[0]), right * (1.0 + noise[1])
            v, w = body_twist(left, right, g.wheel_radius, g.wheel_separation)
            p = self.body.position
            x, y, yaw = float(p.x), float(p.y), float(self.body.angle)
            contact = None
            if v or w:
                nx, ny, nyaw = arc_step(x, y, yaw, v, w, dt)
                contact = self._move_to(nx, ny, nyaw)
                if contact is not None and w and self._move_to(x, y, nyaw) is None:
                    nx, ny = x, y
                elif contact is not None:
                    nx, ny, nyaw = x, y, yaw
            else:
                nx, ny, nyaw = x, y, yaw
            self.steps += 1
            if contact is not None:
                if not self._touching and self.time - self._released_at >= TOUCH_GAP_S:
                    self.collisions.append(Collision(self.time, *contact))
                self._touching = True
            elif self._touching and (v or w):
                self._touching = False
                self._released_at = self.time
            self._wheel_angles[0] += left * dt
            self._wheel_angles[1] += right * dt
            self._twist = (
                ((nx - x) * math.cos(yaw) + (ny - y) * math.sin(yaw)) / dt
                if w == 0.0 or nyaw == yaw
                else math.hypot(nx - x, ny - y) * math.copysign(1.0, v) / dt,
                (nyaw - yaw) / dt,
            )
            self.trajectory.append(
                self.time, self.pose, self._wheel_angles[0], self._wheel_angles[1]
            )

    def run(self, seconds: float) -> None:
        """Advance by ``seconds`` (rounded to whole steps)."""
        self.step(int(round(seconds / self.dt)))

    # -- sensing ------------------------------------------------------------------
    def scan(self) -> np.ndarray:
        """Ranges of one lidar sweep (metres; ``inf`` where nothing is in range).

        All rays at once against the world's edges (walls are their rectangles), which
        is what makes a 360-ray scan cheap; :meth:`ray` asks Pymunk for one ray.
        """
        spec = self.laser
        pose = self.pose
        ox = pose.x + spec.offset * math.cos(pose.yaw)
        oy = pose.y + spec.offset * math.sin(pose.yaw)
        angles = pose.yaw + spec.angles()
        dx, dy = np.cos(angles)[:, None], np.sin(angles)[:, None]
        px, py = self._edges[:, 0] - ox, self._edges[:, 1] - oy
        ex, ey = self._edges[:, 2], self._edges[:, 3]
        with np.errstate(divide="ignore", invalid="ignore"):
            denom = dx * ey - dy * ex
            t = (px * ey - py * ex) / denom
            u = (px * dy - py * dx) / denom
            hit = (np.abs(denom) > 1e-12) & (t >= 0.0) & (u >= 0.0) & (u <= 1.0)
        ranges = np.where(hit, t, math.inf).min(axis=1, initial=math.inf)
        ranges[ranges > spec.range_max] = math.inf
        if self.scan_noise > 0.0:
            ranges = ranges + self.rng.normal(0.0, self.scan_noise, spec.count)
        ranges[ranges < spec.range_min] = math.inf
        return ranges

    def ray(self, angle: float) -> float:
        """Distance to the first wall or obstacle along one ray (Pymunk's segment query)."""
        spec = self.laser
        pose = self.pose
        ox = pose.x + spec.offset * math.cos(pose.yaw)
        oy = pose.y + spec.offset * math.sin(pose.yaw)
        a = pose.yaw + angle
        end = (ox + spec.range_max * math.cos(a), oy + spec.range_max * math.sin(a))
        hit = self.space.segment_query_first((ox, oy), end, 0.0, self._ray_filter)
        return math.inf if hit is None else hit.alpha * spec.range_max


def _world_edges(world: World) -> np.ndarray:
    """Rows (x, y, dx, dy): every edge of the walls' rectangles and of the boxes."""
    polygons = [wall.corners() for wall in world.all_walls()]
    polygons += [box.corners() for box in world.boxes]
    rows = [
        (ax, ay, bx - ax, by - ay)
        for corners in polygons
        for (ax, ay), (bx, by) in zip(corners, corners[1:] + corners[:1])
    ]
    return np.array(rows, dtype=float).reshape(-1, 4)
