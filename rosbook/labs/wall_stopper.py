"""The wall stopper that lab 8's students test: correct, or with one seeded bug.

A student's test file imports ``from wall_stopper import WallStopper, forward_speed``;
``rosbook.labs.lab08`` runs it with this module under that name, seeded with no bug
(the tests must all pass) or with one of ``BUGS`` (one of the tests must fail). One
implementation holds every variant, so a bug is one decision changed, as in real code.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from geometry_msgs.msg import Twist
from rclpy.node import Node
from sensor_msgs.msg import LaserScan

#: Half the cone ahead in which an obstacle stops the robot (10 degrees each side).
CONE = math.radians(10)
#: The parameters' defaults.
SPEED = 0.3
STOP_AT = 0.5

#: Each seeded bug, by name, as a student's feedback describes it.
BUGS = {
    "never_stops": "a node that never stops: it drives on whatever its scan shows",
    "cone_behind": (
        "a node whose cone looks behind the robot: it counts ray angles from the first "
        "ray (angle_min) instead of from straight ahead, so an obstacle ahead is not seen"
    ),
    "stops_late": (
        "a node that stops only for an obstacle closer than stop_at, and drives on for "
        "one at exactly stop_at"
    ),
    "wide_cone": (
        "a node that also stops for an obstacle beside its path (a cone of 45 degrees "
        "each side instead of 10)"
    ),
    "drives_blind": "a node that drives at full speed when the scan holds no range ahead",
    "wrong_topic": "a node that publishes its commands on 'cmd' instead of 'cmd_vel'",
    "ignores_stop_at": (
        "a node that ignores its stop_at parameter and always stops at the default 0.5 m"
    ),
}

_bug: str | None = None


def seed(bug: str | None) -> None:
    """Make this module behave with ``bug`` (a key of ``BUGS``), or correctly (None)."""
    global _bug
    if bug is not None and bug not in BUGS:
        raise ValueError(f"no seeded bug {bug!r}; the bugs: {', '.join(BUGS)}")
    _bug = bug


def forward_speed(
    ranges: Sequence[float],
    angle_min: float,
    angle_increment: float,
    speed: float,
    stop_at: float,
) -> float:
    """``speed``, or 0.0 when a range within ``CONE`` of straight ahead is at most
    ``stop_at`` or when no range lies in the cone."""
    cone = math.radians(45) if _bug == "wide_cone" else CONE
    first = 0.0 if _bug == "cone_behind" else angle_min
    ahead = [r for i, r in enumerate(ranges) if abs(first + i * angle_increment) <= cone]
    if not ahead:
        return speed if _bug == "drives_blind" else 0.0
    if _bug == "never_stops":
        return speed
    closest = min(ahead)
    blocked = closest < stop_at if _bug == "stops_late" else closest <= stop_at
    return 0.0 if blocked else speed


class WallStopper(Node):
    """For each scan on 'scan', publishes one command on 'cmd_vel': ``forward_speed``
    of the scan with the parameters ``speed`` and ``stop_at``."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("wall_stopper", **kwargs)
        self.speed = self.declare_parameter("speed", SPEED).value
        self.stop_at = self.declare_parameter("stop_at", STOP_AT).value
        if _bug == "ignores_stop_at":
            self.stop_at = STOP_AT
        topic = "cmd" if _bug == "wrong_topic" else "cmd_vel"
        self.publisher_ = self.create_publisher(Twist, topic, 10)
        self.subscription = self.create_subscription(LaserScan, "scan", self.on_scan, 10)

    def on_scan(self, msg: LaserScan) -> None:
        cmd = Twist()
        cmd.linear.x = forward_speed(
            msg.ranges, msg.angle_min, msg.angle_increment, self.speed, self.stop_at
        )
        self.publisher_.publish(cmd)
