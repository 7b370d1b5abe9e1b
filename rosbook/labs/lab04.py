"""Checks for robot descriptions, used by lab 4's test cells.

Each ``assert_*`` raises an ``AssertionError`` whose message says what was expected,
what the student's URDF has, and the likely fix. :func:`show_robot` puts a small
picture of the student's robot into the notebook (and so into the feedback page).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence

import numpy as np

from rosbook.labs.deferral import deferrable
from rosbook.robots import urdf
from rosbook.robots.urdf import Robot, URDFError
from rosbook.viz import scene as viz

#: The lab's robot (the lecture's): base box, wheels, caster, as stated in the lab.
#: base_link is the middle of the wheel axle (as the simulator and odometry have it).
BASE_SIZE = (0.6, 0.3, 0.1)
BASE_CENTRE = (-0.2, 0.0, 0.05)
WHEEL_RADIUS = 0.04
WHEEL_LENGTH = 0.05
WHEEL_CENTRES = {"left_wheel": (0.0, 0.2, 0.0), "right_wheel": (0.0, -0.2, 0.0)}
FLOOR_Z = -0.04
LASER_FRAME = (0.0, 0.0, 0.11)
#: What a place error adds when the robot was written around another origin.
AXLE_HINT = (
    "; base_link is the middle of the wheel axle, so the wheel centres are at x = 0, z = 0 "
    "and the other parts are placed from there"
)


def _fmt(values: Sequence[float]) -> str:
    return "(" + ", ".join(f"{round(float(v), 4) + 0.0:.4g}" for v in values) + ")"


def load_student_urdf(xml: object, what: str = "DIFF_DRIVE_URDF") -> Robot:
    """Load a student's URDF string; a failure names the element and the problem."""
    # Text only: urdf.load reads a string that does not start with "<" as a file's path.
    if not isinstance(xml, str) or "<robot" not in xml or not xml.lstrip().startswith("<"):
        raise AssertionError(
            f"{what} must be a string holding your URDF (<robot ...>), got {xml!r:.80}"
        )
    try:
        root = ET.fromstring(xml)
    except ET.ParseError as error:
        raise AssertionError(f"{what} is not well-formed XML: {error}") from None
    for joint in root.findall("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if child is not None and child.get("link") == "base_link" and parent is not None:
            raise AssertionError(
                f"joint {joint.get('name')!r} has parent {parent.get('link')!r} and child "
                "'base_link': parent and child are swapped. base_link is the root of the "
                'tree, so a joint that attaches a wheel has <parent link="base_link"/> and '
                f'<child link="{parent.get("link")}"/>'
            )
    try:
        return urdf.load(xml)
    except URDFError as error:
        raise AssertionError(f"{what} is not a valid URDF: {error}") from None


def show_robot(robot: Robot, title: str = "your robot") -> None:
    """Display a small picture of ``robot`` (top and side views) in the notebook (when
    graded: in the test cell's output, the picture of the URDF the judge checked)."""
    from IPython.display import Image, display

    from rosbook.labs import remote  # not before: a lab without nodes needs no rclpy

    picture = Image(data=viz.sketch(robot, title=title), format="png")
    j = remote.judging()
    if j is not None:
        j.show(picture)
    else:
        display(picture)


def assert_diff_drive_tree(robot: Robot) -> None:
    """base_link is the root; the wheels hang on continuous joints, the caster on a fixed one."""
    for link in ("base_link", "left_wheel", "right_wheel", "caster", "laser_frame"):
        assert link in robot.links, (
            f"there is no link named {link!r}; your links are {', '.join(robot.links)}"
        )
    assert robot.root == "base_link", (
        f"the root of your tree is {robot.root!r}, not 'base_link': every other link must "
        "hang below base_link"
    )
    for link, kind in (
        ("left_wheel", "continuous"),
        ("right_wheel", "continuous"),
        ("caster", "fixed"),
        ("laser_frame", "fixed"),
    ):
        joint = robot.parent_joint(link)
        assert joint is not None, f"no joint attaches {link!r}"
        assert joint.parent == "base_link", (
            f"joint {joint.name!r} attaches {link!r} to {joint.parent!r}; attach it to base_link"
        )
        if kind == "continuous":
            assert joint.type == "continuous", (
                f"joint {joint.name!r} (base_link -> {link}) is {joint.type!r}; a wheel turns "
                'without limits, so its joint is type="continuous"'
                + (" (a fixed wheel cannot turn at all)" if joint.type == "fixed" else "")
            )
        else:
            assert joint.type == "fixed", (
                f"joint {joint.name!r} (base_link -> {link}) is {joint.type!r}; the lab's "
                f'{link} is attached with type="fixed" (nothing drives it)'
            )


def _cylinder(robot: Robot, link: str) -> tuple[float, float, np.ndarray] | None:
    """Radius, length and pose (in the root frame) of the link's first cylinder visual."""
    for part in robot.model.link_map[link].visuals:
        if part.geometry.cylinder is not None:
            origin = np.eye(4) if part.origin is None else np.asarray(part.origin)
            c = part.geometry.cylinder
            return float(c.radius), float(c.length), robot.pose(link) @ origin
    return None


def assert_rolls_forward(robot: Robot, wheel: str, angle: float = 0.1) -> None:
    """Turning ``wheel``'s joint by a positive angle rolls the robot forward (+x).

    The wheel's axle (its cylinder's axis) must be the joint's axis, along base_link's
    y; then the point of the rim touching the floor is followed as the joint turns: the
    robot moves opposite to it (rolling without slipping), and must move +x.
    """
    joint = robot.parent_joint(wheel)
    assert joint is not None, f"no joint attaches {wheel!r}"
    axis = robot.axis_in_root(joint.name)
    shape = _cylinder(robot, wheel)
    assert shape is not None, f"{wheel!r} has no <cylinder> visual"
    radius, _, pose = shape
    axle = pose[:3, 2]
    assert abs(float(np.dot(axle, axis))) > 0.99, (
        f"{wheel!r} turns about {_fmt(axis)} (base_link frame) but its cylinder's axle "
        f"points along {_fmt(axle)}: a wheel must turn about its own axle. A URDF "
        'cylinder stands along z; roll the wheel\'s frame with rpy="1.570796 0 0" in the '
        "joint's <origin> and give the axis in that frame"
    )
    assert abs(axis[1]) > 0.99, (
        f"{wheel!r} turns about {_fmt(axis)} in base_link, but a wheel that rolls along x "
        "turns about base_link's y axis"
        + (
            ": it lies flat and spins like a turntable. Lay it on its side with "
            "rpy=\"1.570796 0 0\" in the joint's <origin>; then the wheel's own z is "
            "base_link's -y"
            if abs(axis[2]) > 0.99
            else "; with the joint rpy (pi/2, 0, 0) the wheel's own z is base_link's -y"
        )
    )
    contact = pose[:3, 3] + np.array([0.0, 0.0, -radius])
    before = robot.pose(wheel)
    point = np.linalg.solve(before, np.append(contact, 1.0))
    after = robot.pose(wheel, {joint.name: angle}) @ point
    motion = -(after[:3] - contact)  # the robot moves opposite to its contact point
    forward = motion[0] / (radius * angle)
    assert forward > 0, (
        f"a positive rotation of {joint.name!r} rolls the robot backwards (-x): its axis is "
        f"{_fmt(axis)} in base_link, it must be +y (0, 1, 0) so that a positive wheel speed "
        "drives forward; reverse the sign of its <axis xyz>"
    )
    assert abs(forward - 1) < 0.05, (
        f"rolling {wheel!r} by {angle} rad moves the robot {motion[0]:.4f} m along x, "
        f"expected {radius * angle:.4f} m (radius x angle)"
    )


def assert_diff_drive_dimensions(robot: Robot) -> None:
    """Base box, wheels and caster have the stated sizes and places."""
    base = [v for v in robot.model.link_map["base_link"].visuals if v.geometry.box is not None]
    assert base, "base_link has no <box> visual"
    size = tuple(float(v) for v in base[0].geometry.box.size)
    assert np.allclose(size, BASE_SIZE, atol=1e-6), (
        f"base_link's box is {_fmt(size)} m, expected {_fmt(BASE_SIZE)}"
    )
    origin = np.eye(4) if base[0].origin is None else np.asarray(base[0].origin)
    assert np.allclose(origin[:3, 3], BASE_CENTRE, atol=1e-3), (
        f"base_link's box is centred at {_fmt(origin[:3, 3])} in base_link, expected "
        f"{_fmt(BASE_CENTRE)} (give its <visual> an <origin xyz>){AXLE_HINT}"
    )
    for wheel, centre in WHEEL_CENTRES.items():
        shape = _cylinder(robot, wheel)
        assert shape is not None, f"{wheel!r} has no <cylinder> visual"
        radius, length, pose = shape
        assert math.isclose(radius, WHEEL_RADIUS, abs_tol=1e-6) and math.isclose(
            length, WHEEL_LENGTH, abs_tol=1e-6
        ), (
            f"{wheel!r} is a cylinder of radius {radius} m and length {length} m; expected "
            f"radius {WHEEL_RADIUS} and length {WHEEL_LENGTH}"
        )
        got = robot.position(wheel)
        assert np.allclose(got, centre, atol=1e-3), (
            f"{wheel!r}'s centre is at {_fmt(got)} in base_link, expected {_fmt(centre)}"
            + (
                " (left is +y, right is -y)"
                if np.allclose(got, np.multiply(centre, (1, -1, 1)), atol=1e-3)
                else AXLE_HINT
            )
        )
    laser = robot.position("laser_frame")
    assert np.allclose(laser, LASER_FRAME, atol=1e-3), (
        f"laser_frame is at {_fmt(laser)} in base_link, expected {_fmt(LASER_FRAME)}"
    )
    lowest = _lowest_point(robot, "caster")
    assert lowest is not None, "the caster has no <sphere> visual"
    assert math.isclose(lowest, FLOOR_Z, abs_tol=1e-3), (
        f"the caster reaches down to z = {lowest:.3f} m, the wheels to z = {FLOOR_Z}: the "
        "robot would not stand level"
    )


def _lowest_point(robot: Robot, link: str) -> float | None:
    for part in robot.model.link_map[link].visuals:
        if part.geometry.sphere is not None:
            origin = np.eye(4) if part.origin is None else np.asarray(part.origin)
            return float((robot.pose(link) @ origin)[2, 3] - part.geometry.sphere.radius)
    return None


def assert_close(what: str, got: object, expected: float, tol: float = 1e-6) -> None:
    """``got`` is a number within ``tol`` of ``expected``."""
    assert isinstance(got, (int, float, np.floating)), f"{what} must be a float, got {got!r}"
    assert abs(float(got) - expected) <= tol, (
        f"{what}: expected {expected:.6f}, got {float(got):.6f}"
    )


def assert_position(
    what: str, function: Callable[..., object], args: Sequence[float], expected: Sequence[float]
) -> None:
    """``function(*args)`` returns an (x, y, z) within 1e-6 of ``expected`` (``args``
    are passed as Python floats: plain data, whether ``function`` is the student's own
    or a handle to it in the student's kernel)."""
    args = [float(a) for a in args]
    got = function(*args)
    assert isinstance(got, (tuple, list, np.ndarray)) and len(got) == 3, (
        f"{what}{tuple(args)} must return (x, y, z), got {got!r}"
    )
    values = [float(v) for v in got]
    assert np.allclose(values, expected, atol=1e-6), (
        f"{what}{tuple(round(a, 4) for a in args)}: expected {_fmt(expected)}, got {_fmt(values)}"
    )


def nested_robot() -> str:
    """A robot whose left wheel hangs below a turned intermediate link (hidden checks).

    The two wheel joints have different parents, so the distance between their
    ``<origin xyz>`` values is not the wheel separation: only forward kinematics gives it.
    """
    return """<robot name="nested">
  <link name="base_footprint"/><link name="base_link"/><link name="chassis"/>
  <link name="left_wheel"/><link name="right_wheel"/>
  <joint name="footprint" type="fixed">
    <parent link="base_footprint"/><child link="base_link"/><origin xyz="0 0 0.07"/>
  </joint>
  <joint name="chassis_joint" type="fixed">
    <parent link="base_link"/><child link="chassis"/>
    <origin xyz="0.05 0 0.02" rpy="0 0 1.570796"/>
  </joint>
  <joint name="left_wheel_joint" type="continuous">
    <parent link="chassis"/><child link="left_wheel"/>
    <origin xyz="0.13 0.01 -0.02" rpy="-1.570796 0 -1.570796"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="right_wheel_joint" type="continuous">
    <parent link="base_link"/><child link="right_wheel"/>
    <origin xyz="0.04 -0.14 0" rpy="-1.570796 0 0"/><axis xyz="0 0 1"/>
  </joint>
</robot>"""


def turtlebot_like_robot(half_separation: float = 0.08) -> str:
    """TurtleBot3-Burger-like wheel placement (by default, wheel separation 0.160 m)."""
    wheel = """
  <link name="{side}_wheel"/>
  <joint name="{side}_wheel_joint" type="continuous">
    <parent link="base_link"/><child link="{side}_wheel"/>
    <origin xyz="0.0 {y} 0.023" rpy="-1.57 0 0"/><axis xyz="0 0 1"/>
  </joint>"""
    return (
        '<robot name="burger"><link name="base_footprint"/><link name="base_link"/>'
        '<joint name="base_joint" type="fixed"><parent link="base_footprint"/>'
        '<child link="base_link"/><origin xyz="0 0 0.010"/></joint>'
        + wheel.format(side="left", y=half_separation)
        + wheel.format(side="right", y=-half_separation)
        + "</robot>"
    )


deferrable(globals())
