"""The book's robot descriptions, shipped with the package (not only in the repository).

``DIFF_DRIVE_URDF`` is the lecture's differential-drive robot: the one the URDF chapter
writes step by step, lab 4 asks for, and :mod:`rosbook.sim` simulates (its wheel joints
turn forwards for positive angles, as the simulator's wheel angles do).
"""

from __future__ import annotations

from pathlib import Path

from rosbook.urdf import Robot, load

#: The lecture robot's URDF file.
DIFF_DRIVE_URDF = Path(__file__).with_name("diff_drive.urdf")
#: Its wheel joints (continuous; a positive angle rolls the robot forwards).
LEFT_WHEEL_JOINT = "base_link_left_wheel"
RIGHT_WHEEL_JOINT = "base_link_right_wheel"
WHEEL_JOINTS = (LEFT_WHEEL_JOINT, RIGHT_WHEEL_JOINT)


def diff_drive() -> Robot:
    """The lecture robot, loaded (a fresh :class:`~rosbook.urdf.Robot` each call)."""
    return load(DIFF_DRIVE_URDF)
