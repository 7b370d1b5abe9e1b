"""Lab 4's checks as the judge runs them: every verdict from a value the kernel returns.

The student's URDF string and functions live in the kernel; the judge asks for the
string and calls the functions with its own inputs (hidden ones included), then judges
the returned values in its own process with ``rosbook.labs.lab04``. The arm's URDF is
read from the released lab (a locked cell), not from the kernel.
"""

from __future__ import annotations

import math

import nbformat
import numpy as np

from autograder.config import LABS
from autograder.judge import CheckFailed, Judgement
from rosbook.labs import lab04 as urdf_checks
from rosbook.robots import urdf

LAB = "lab04_urdf"


def check_diff_drive_urdf(j: Judgement) -> None:
    robot = urdf_checks.load_student_urdf(j.value("DIFF_DRIVE_URDF"))
    urdf_checks.assert_diff_drive_tree(robot)
    urdf_checks.assert_rolls_forward(robot, "left_wheel")
    urdf_checks.assert_rolls_forward(robot, "right_wheel")
    urdf_checks.assert_diff_drive_dimensions(robot)
    joint = robot.parent_joint("left_wheel")
    assert joint is not None
    for angle in (0.5, -0.3):
        turned = robot.pose("left_wheel", {joint.name: angle})
        if not np.allclose(turned[:3, 3], robot.position("left_wheel"), atol=1e-9):
            raise CheckFailed(
                "turning the left wheel moves its centre: the wheel's frame must be at its centre"
            )


def check_wheel_separation(j: Judgement) -> None:
    for what, robot, expected in (
        ("a TurtleBot-like robot", urdf_checks.turtlebot_like_robot(), 0.16),
        ("a wider robot", urdf_checks.turtlebot_like_robot(0.25), 0.5),
        ("a robot whose wheels hang below a turned link", urdf_checks.nested_robot(), None),
    ):
        if expected is None:
            reference = urdf.load(robot)
            expected = float(
                np.linalg.norm(reference.position("left_wheel") - reference.position("right_wheel"))
            )
        got = j.call_function("wheel_separation", robot)
        urdf_checks.assert_close(f"wheel_separation of {what}", got, expected)


def arm_urdf() -> str:
    """ARM_URDF as the released lab defines it (the instructor's locked cell)."""
    released = nbformat.read(LABS / LAB / f"{LAB}.ipynb", as_version=4)
    cell = next(
        c
        for c in released.cells
        if c.get("metadata", {}).get("nbgrader", {}).get("grade_id") == "arm_urdf"
    )
    names: dict[str, object] = {}
    exec(cell.source, names)  # noqa: S102 - the instructor's own cell, not the student's
    return str(names["ARM_URDF"])


def check_arm_fk(j: Judgement) -> None:
    arm = urdf.load(arm_urdf())
    rng = np.random.default_rng(404)
    angles = [(0.0, 0.0), (math.pi / 2, -math.pi / 2), (0.3, 1.1), (-2.0, 0.7), (3.0, -3.0)]
    angles += [tuple(float(a) for a in rng.uniform(-3.1, 3.1, 2)) for _ in range(5)]
    for q1, q2 in angles:
        expected = arm.position("tool", {"shoulder": q1, "elbow": q2})
        urdf_checks.assert_position(
            "end_effector_position",
            lambda *args: j.call_function("end_effector_position", *args),
            (q1, q2),
            expected,
        )


CHECKS = {
    "test_diff_drive_urdf": check_diff_drive_urdf,
    "test_wheel_separation": check_wheel_separation,
    "test_arm_fk": check_arm_fk,
}
