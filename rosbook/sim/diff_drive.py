"""Differential-drive kinematics: body twist (v, w) to wheel speeds and back.

A differential-drive robot has two driven wheels on one axle, ``wheel_separation``
apart, each of radius ``wheel_radius``. The point midway between the wheels moves at
``v`` (m/s, along the robot's x axis) and the robot turns at ``w`` (rad/s, counter-
clockwise seen from above)::

    v = r (right + left) / 2        w = r (right - left) / L

where ``left`` and ``right`` are the wheels' angular speeds in rad/s. These are pure
functions so that the book, the simulator and lab 5 share one definition.
"""

from __future__ import annotations

import math


def wheel_speeds(
    v: float, w: float, wheel_radius: float, wheel_separation: float
) -> tuple[float, float]:
    """(left, right) wheel speeds in rad/s that make the body move at (v, w)."""
    left = (v - w * wheel_separation / 2.0) / wheel_radius
    right = (v + w * wheel_separation / 2.0) / wheel_radius
    return left, right


def body_twist(
    left: float, right: float, wheel_radius: float, wheel_separation: float
) -> tuple[float, float]:
    """(v, w) of the body when the wheels turn at ``left`` and ``right`` rad/s."""
    v = wheel_radius * (right + left) / 2.0
    w = wheel_radius * (right - left) / wheel_separation
    return v, w


def arc_step(
    x: float, y: float, yaw: float, v: float, w: float, dt: float
) -> tuple[float, float, float]:
    """The exact pose after driving at constant (v, w) for ``dt`` seconds.

    The robot moves on a circle of radius v / w (a straight line when w = 0); this is
    the closed form the simulator is checked against.
    """
    if abs(w) < 1e-12:
        return x + v * dt * math.cos(yaw), y + v * dt * math.sin(yaw), yaw
    radius = v / w
    new_yaw = yaw + w * dt
    return (
        x + radius * (math.sin(new_yaw) - math.sin(yaw)),
        y - radius * (math.cos(new_yaw) - math.cos(yaw)),
        new_yaw,
    )


def wrap_angle(angle: float) -> float:
    """``angle`` in (-pi, pi]."""
    wrapped = math.remainder(angle, 2.0 * math.pi)
    return math.pi if wrapped == -math.pi else wrapped
