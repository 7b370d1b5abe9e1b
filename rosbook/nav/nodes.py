"""The navigation nodes: ``Mapper`` (``scan`` + ``odom`` -> ``map``), ``Planner``
(``map`` + ``odom`` -> ``plan``, A*) and ``PathFollower`` (``plan`` + ``odom`` + ``scan``
-> ``cmd_vel``). Each is an ordinary rclpy node that runs on simulated time as well as on
the wall clock; the chapter "Finding the way" runs them on the book's simulator."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import OccupancyGrid, Odometry, Path
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import LaserScan

from rosbook.nav.grid import GridSpec, OccupancyMapper, from_msg, to_msg
from rosbook.nav.planner import NoPath, plan
from rosbook.sim.node import yaw_of

#: The map is latched, as map_server's and slam_toolbox's are: a late subscriber gets it.
MAP_QOS = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)


def odom_pose(msg: Odometry) -> tuple[float, float, float]:
    """(x, y, yaw) of an ``Odometry`` message."""
    p = msg.pose.pose.position
    return (p.x, p.y, yaw_of(msg))


class Mapper(Node):
    """Builds an occupancy grid from ``scan`` at the poses ``odom`` reports; publishes it
    on ``map`` every ``period`` seconds."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("mapper", **kwargs)
        bounds = self.declare_parameter("bounds", [-5.0, -5.0, 5.0, 5.0]).value
        resolution = self.declare_parameter("resolution", 0.05).value
        period = self.declare_parameter("period", 1.0).value
        self.mapper = OccupancyMapper(GridSpec.covering(tuple(bounds), resolution))
        self.pose: tuple[float, float, float] | None = None
        self.create_subscription(Odometry, "odom", self.on_odom, 10)
        self.create_subscription(LaserScan, "scan", self.on_scan, 10)
        self.publisher_ = self.create_publisher(OccupancyGrid, "map", MAP_QOS)
        self.timer = self.create_timer(period, self.publish_map)

    def on_odom(self, msg: Odometry) -> None:
        self.pose = odom_pose(msg)

    def on_scan(self, msg: LaserScan) -> None:
        if self.pose is not None:
            self.mapper.add_scan(
                self.pose, msg.ranges, msg.angle_min, msg.angle_increment, msg.range_max
            )

    def publish_map(self) -> None:
        if self.mapper.scans:
            stamp = self.get_clock().now().to_msg()
            self.publisher_.publish(to_msg(self.mapper.occupancy(), self.mapper.spec, stamp))


class Planner(Node):
    """Plans from the robot's pose to the ``goal`` parameter (x, y) on each new ``map``
    with A*, for a robot of ``radius``; publishes the path on ``plan``."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("planner", **kwargs)
        self.goal = tuple(self.declare_parameter("goal", [0.0, 0.0]).value)
        self.radius = self.declare_parameter("radius", 0.35).value
        self.pose: tuple[float, float, float] | None = None
        self.plans = 0
        self.failures = 0
        self.create_subscription(Odometry, "odom", self.on_odom, 10)
        self.create_subscription(OccupancyGrid, "map", self.on_map, MAP_QOS)
        self.publisher_ = self.create_publisher(Path, "plan", 10)

    def on_odom(self, msg: Odometry) -> None:
        self.pose = odom_pose(msg)

    def on_map(self, msg: OccupancyGrid) -> None:
        if self.pose is None:
            return
        grid, spec = from_msg(msg)
        try:
            points = plan(grid, spec, self.pose[:2], self.goal, self.radius)
        except NoPath as error:
            self.failures += 1
            self.get_logger().warning(f"no plan: {error}")
            return
        path = Path()
        path.header.stamp = msg.header.stamp
        path.header.frame_id = msg.header.frame_id
        for x, y in points:
            pose = PoseStamped()
            pose.header = path.header
            pose.pose.position.x, pose.pose.position.y = float(x), float(y)
            pose.pose.orientation.w = 1.0
            path.poses.append(pose)
        self.publisher_.publish(path)
        self.plans += 1


def lookahead_point(
    path: list[tuple[float, float]], position: tuple[float, float], lookahead: float
) -> tuple[float, float]:
    """The point ``lookahead`` metres along ``path`` (a polyline) beyond the point of it
    nearest ``position``; the path's end if it is closer than that."""
    if len(path) < 2:
        return path[-1]
    a = np.asarray(path[:-1], dtype=float)
    ab = np.asarray(path[1:], dtype=float) - a
    lengths = np.hypot(ab[:, 0], ab[:, 1])
    t = np.clip(
        np.sum((np.asarray(position) - a) * ab, axis=1) / np.maximum(lengths**2, 1e-12), 0, 1
    )
    gaps = np.hypot(*(a + t[:, None] * ab - np.asarray(position)).T)
    i = int(np.argmin(gaps))
    left = lookahead + t[i] * lengths[i]  # measured from the start of segment i
    while i < len(lengths) and left > lengths[i]:
        left -= lengths[i]
        i += 1
    if i == len(lengths):
        return path[-1]
    point = a[i] + ab[i] * (left / max(lengths[i], 1e-12))
    return (float(point[0]), float(point[1]))


class PathFollower(Node):
    """Follows the latest ``plan`` by pure pursuit (steering to the point ``lookahead``
    metres ahead on it, ``lookahead_point``), slowing down for what the lidar sees ahead,
    and stops at its end."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("path_follower", **kwargs)
        self.speed = self.declare_parameter("speed", 0.3).value
        self.lookahead = self.declare_parameter("lookahead", 0.5).value
        self.tolerance = self.declare_parameter("tolerance", 0.1).value
        #: Ahead of the lidar, the robot stops at this range and slows from twice it.
        self.stop_at = self.declare_parameter("stop_at", 0.3).value
        self.path: list[tuple[float, float]] = []
        self.pose: tuple[float, float, float] | None = None
        self.ahead = math.inf
        self.arrived = False
        self.create_subscription(Path, "plan", self.on_plan, 10)
        self.create_subscription(Odometry, "odom", self.on_odom, 10)
        self.create_subscription(LaserScan, "scan", self.on_scan, 10)
        self.publisher_ = self.create_publisher(Twist, "cmd_vel", 10)
        self.timer = self.create_timer(0.05, self.on_timer)

    def on_plan(self, msg: Path) -> None:
        self.path = [(p.pose.position.x, p.pose.position.y) for p in msg.poses]

    def on_odom(self, msg: Odometry) -> None:
        self.pose = odom_pose(msg)

    def on_scan(self, msg: LaserScan) -> None:
        cone = [
            r
            for i, r in enumerate(msg.ranges)
            if abs(msg.angle_min + i * msg.angle_increment) <= math.radians(30)
        ]
        self.ahead = min(cone, default=math.inf)

    def target(self) -> tuple[float, float]:
        """The point ``lookahead`` metres further along the path than the point of the
        path nearest the robot."""
        assert self.pose is not None
        return lookahead_point(self.path, self.pose[:2], self.lookahead)

    def on_timer(self) -> None:
        cmd = Twist()
        if self.pose is not None and self.path and not self.arrived:
            x, y, yaw = self.pose
            remaining = math.dist(self.path[-1], (x, y))
            if remaining < self.tolerance:
                self.arrived = True
                self.get_logger().info(f"arrived at {self.path[-1]}")
            else:
                tx, ty = self.target()
                alpha = math.remainder(math.atan2(ty - y, tx - x) - yaw, 2 * math.pi)
                cmd.angular.z = max(-1.2, min(1.2, 2.0 * alpha))
                if abs(alpha) < 0.6:
                    brake = min(1.0, max(0.0, (self.ahead - self.stop_at) / self.stop_at))
                    cmd.linear.x = min(self.speed, 0.8 * remaining) * math.cos(alpha) * brake
        self.publisher_.publish(cmd)
