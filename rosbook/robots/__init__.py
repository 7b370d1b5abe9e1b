"""The book's robot descriptions, shipped with the package (not only in the repository).

``DIFF_DRIVE_URDF`` is the lecture's differential-drive robot: the one the URDF chapter
writes step by step, lab 4 asks for, and :mod:`rosbook.sim` simulates (its wheel joints
turn forwards for positive angles, as the simulator's wheel angles do). ``R2D2_URDF``
and ``TURTLEBOT_BURGER_URDF`` are robots written elsewhere, redrawn for the book (the
burger is a ROS package of its own, ``turtlebot3_description/``, in its usual layout:
``package.xml``, ``urdf/`` and the ``meshes/`` its ``package://`` URIs name).
"""

from __future__ import annotations

from pathlib import Path

from rosbook.robots.urdf import Robot, load

#: The folder of the robot descriptions.
FOLDER = Path(__file__).parent
#: The lecture robot's URDF file.
DIFF_DRIVE_URDF = FOLDER / "diff_drive.urdf"
#: The ROS URDF tutorial's r2d2, with boxes for its finger meshes.
R2D2_URDF = FOLDER / "r2d2.urdf"
#: A TurtleBot3-Burger-style robot whose parts are STL meshes (stand-in shapes).
TURTLEBOT_BURGER_URDF = FOLDER / "turtlebot3_description" / "urdf" / "turtlebot_burger.urdf"
#: Its wheel joints (continuous; a positive angle rolls the robot forwards).
LEFT_WHEEL_JOINT = "base_link_left_wheel"
RIGHT_WHEEL_JOINT = "base_link_right_wheel"
WHEEL_JOINTS = (LEFT_WHEEL_JOINT, RIGHT_WHEEL_JOINT)


def diff_drive() -> Robot:
    """The lecture robot, loaded (a fresh :class:`~rosbook.robots.urdf.Robot` each call)."""
    return load(DIFF_DRIVE_URDF)
