"""Differential-drive kinematics against hand-worked cases and the closed form."""

from __future__ import annotations

import math

import pytest

from rosbook.sim.diff_drive import arc_step, body_twist, wheel_speeds, wrap_angle

R, L = 0.04, 0.4  # the lecture robot: wheel radius, wheel separation


def test_driving_straight_turns_both_wheels_at_v_over_r() -> None:
    assert wheel_speeds(0.2, 0.0, R, L) == pytest.approx((5.0, 5.0))


def test_turning_in_place_turns_the_wheels_opposite_ways() -> None:
    left, right = wheel_speeds(0.0, 1.0, R, L)
    assert (left, right) == pytest.approx((-5.0, 5.0))


def test_turning_left_needs_the_right_wheel_faster() -> None:
    left, right = wheel_speeds(0.3, 0.5, R, L)
    assert right > left > 0
    assert (left, right) == pytest.approx(((0.3 - 0.1) / R, (0.3 + 0.1) / R))


@pytest.mark.parametrize("v, w", [(0.0, 0.0), (0.25, 0.0), (0.0, -1.2), (0.3, 0.7), (-0.2, 0.4)])
def test_body_twist_inverts_wheel_speeds(v: float, w: float) -> None:
    assert body_twist(*wheel_speeds(v, w, R, L), R, L) == pytest.approx((v, w), abs=1e-12)


@pytest.mark.parametrize("left, right", [(1.0, 1.0), (-3.0, 3.0), (2.5, 7.0)])
def test_wheel_speeds_invert_body_twist(left: float, right: float) -> None:
    assert wheel_speeds(*body_twist(left, right, R, L), R, L) == pytest.approx((left, right))


def test_constant_twist_moves_on_a_circle_of_radius_v_over_w() -> None:
    v, w = 0.3, 0.6
    radius = v / w
    for t in (0.5, 1.0, 3.0, 7.0):
        x, y, yaw = arc_step(0.0, 0.0, 0.0, v, w, t)
        assert math.hypot(x, y - radius) == pytest.approx(radius, abs=1e-12)
        assert yaw == pytest.approx(w * t)
    # a full turn comes back to the start
    x, y, _ = arc_step(0.0, 0.0, 0.0, v, w, 2 * math.pi / w)
    assert (x, y) == pytest.approx((0.0, 0.0), abs=1e-12)


def test_zero_turn_rate_is_a_straight_line() -> None:
    assert arc_step(1.0, 2.0, math.pi / 2, 0.5, 0.0, 2.0) == pytest.approx((1.0, 3.0, math.pi / 2))


def test_wrap_angle_stays_in_minus_pi_to_pi() -> None:
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert wrap_angle(-math.pi) == pytest.approx(math.pi)
    assert wrap_angle(0.3) == 0.3
