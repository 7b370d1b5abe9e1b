"""rosbook.robots.urdf: loading, validation messages, the link tree and forward kinematics."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yourdfpy

from rosbook import robots
from rosbook.robots import DIFF_DRIVE_URDF, urdf
from rosbook.robots.urdf import URDFError

ROBOTS = robots.FOLDER  # the example robots ship with rosbook
DIFF_DRIVE = DIFF_DRIVE_URDF  # the lecture robot ships with rosbook
R2D2 = ROBOTS / "r2d2.urdf"
TURTLEBOT = robots.TURTLEBOT_BURGER_URDF

ARM = """<robot name="arm">
  <link name="base_link"/>
  <link name="upper_arm"/>
  <link name="forearm"/>
  <link name="tool"/>
  <joint name="shoulder" type="revolute">
    <parent link="base_link"/><child link="upper_arm"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-3.14" upper="3.14" effort="10" velocity="1"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="upper_arm"/><child link="forearm"/>
    <origin xyz="0.5 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3.14" upper="3.14" effort="10" velocity="1"/>
  </joint>
  <joint name="tool_joint" type="fixed">
    <parent link="forearm"/><child link="tool"/>
    <origin xyz="0.3 0 0"/>
  </joint>
</robot>"""


def robot_xml(links: str, joints: str) -> str:
    return f'<robot name="r">{links}{joints}</robot>'


LINKS = '<link name="base_link"/><link name="a"/><link name="b"/>'


def joint(name: str, parent: str, child: str, kind: str = "fixed", extra: str = "") -> str:
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/>'
        f'<child link="{child}"/>{extra}</joint>'
    )


def test_the_lecture_robot_loads_as_a_tree_below_base_link() -> None:
    robot = urdf.load(DIFF_DRIVE)
    assert robot.root == "base_link"
    assert sorted(robot.children("base_link")) == [
        "caster",
        "laser_frame",
        "left_wheel",
        "right_wheel",
    ]
    assert robot.joint("base_link_left_wheel").type == "continuous"
    assert robot.moving_joints == ["base_link_left_wheel", "base_link_right_wheel"]
    assert robot.tree().splitlines() == [
        "base_link",
        "├─ base_link_left_wheel (continuous) -> left_wheel",
        "├─ base_link_right_wheel (continuous) -> right_wheel",
        "├─ base_link_caster (fixed) -> caster",
        "└─ base_link_laser (fixed) -> laser_frame",
    ]


def test_a_urdf_string_loads_like_a_file() -> None:
    from_text = urdf.load(DIFF_DRIVE.read_text())
    from_file = urdf.load(DIFF_DRIVE)
    assert from_text.links == from_file.links
    np.testing.assert_allclose(from_text.pose("left_wheel"), from_file.pose("left_wheel"))


def test_wheel_frame_is_rolled_by_rpy_half_pi() -> None:
    """rpy (pi/2, 0, 0): the wheel's y axis is the base's z, its z axis the base's -y."""
    pose = urdf.load(DIFF_DRIVE).pose("right_wheel")
    expected = np.array(
        [[1, 0, 0, 0.0], [0, 0, -1, -0.2], [0, 1, 0, 0.0], [0, 0, 0, 1]], dtype=float
    )
    np.testing.assert_allclose(pose, expected, atol=1e-6)


def test_turning_a_wheel_turns_its_frame_but_not_its_centre() -> None:
    robot = urdf.load(DIFF_DRIVE)
    turned = robot.pose("left_wheel", {"base_link_left_wheel": math.pi / 2})
    np.testing.assert_allclose(turned[:3, 3], [0.0, 0.2, 0.0], atol=1e-9)
    # The rim point that was at the wheel's +x (base +x, the front) is now at the top:
    # axis 0 0 -1 in a frame whose z is the base's -y is a turn about +y (rolling forward).
    rim = turned @ np.array([0.04, 0, 0, 1])
    np.testing.assert_allclose(rim[:3], [0.0, 0.2, -0.04], atol=1e-6)
    np.testing.assert_allclose(robot.axis_in_root("base_link_left_wheel"), [0, 1, 0], atol=1e-6)


def test_arm_end_effector_matches_the_hand_computed_position() -> None:
    robot = urdf.load(ARM)
    for q1, q2 in [(0, 0), (math.pi / 2, -math.pi / 2), (0.3, 1.1), (-2.0, 0.7)]:
        x = 0.5 * math.cos(q1) + 0.3 * math.cos(q1 + q2)
        y = 0.5 * math.sin(q1) + 0.3 * math.sin(q1 + q2)
        got = robot.position("tool", {"shoulder": q1, "elbow": q2})
        np.testing.assert_allclose(got, [x, y, 0.1], atol=1e-9)
    np.testing.assert_allclose(
        robot.position("tool", {"shoulder": math.pi / 2, "elbow": -math.pi / 2}),
        [0.3, 0.5, 0.1],
        atol=1e-9,
    )


def test_a_joint_moves_only_its_subtree() -> None:
    robot = urdf.load(R2D2)
    before = robot.poses()
    after = robot.poses({"gripper_extension": -0.2})
    moved = {link for link in robot.links if not np.allclose(before[link], after[link])}
    assert moved == {"gripper_pole", "left_gripper", "right_gripper"}
    np.testing.assert_allclose(
        after["gripper_pole"][:3, 3] - before["gripper_pole"][:3, 3], [-0.2, 0, 0], atol=1e-9
    )


def test_forward_kinematics_agrees_with_yourdfpy() -> None:
    robot = urdf.load(R2D2)
    reference = yourdfpy.URDF.load(str(R2D2), load_meshes=False)
    rng = np.random.default_rng(4)
    for _ in range(3):
        q = {name: float(rng.uniform(-0.3, 0.3)) for name in robot.moving_joints}
        reference.update_cfg(q)
        for link in robot.links:
            np.testing.assert_allclose(
                robot.pose(link, q), reference.get_transform(link, "base_link"), atol=1e-9
            )


def test_unknown_names_are_reported() -> None:
    robot = urdf.load(DIFF_DRIVE)
    with pytest.raises(KeyError, match="no link 'wheel'"):
        robot.pose("wheel")
    with pytest.raises(KeyError, match="no joint"):
        robot.pose("left_wheel", {"left_wheel": 1.0})


def test_third_party_robots_load() -> None:
    r2d2 = urdf.load(R2D2)
    assert r2d2.root == "base_link" and len(r2d2.links) == 14
    assert r2d2.joint("gripper_extension").type == "prismatic"
    burger = urdf.load(TURTLEBOT)
    assert burger.root == "base_footprint"
    assert set(burger.children("base_link")) == {
        "wheel_left_link",
        "wheel_right_link",
        "caster_back_link",
        "imu_link",
        "base_scan",
    }
    # TurtleBot's wheels are turned by rpy (-pi/2, 0, 0) with axis z: they roll about +y.
    np.testing.assert_allclose(burger.axis_in_root("wheel_left_joint"), [0, 1, 0], atol=1e-3)


MALFORMED = {
    "unknown parent link": (
        robot_xml(LINKS, joint("j1", "base", "a")),
        "<joint name=\"j1\">: unknown parent link 'base'; the links are base_link, a, b",
    ),
    "unknown child link": (
        robot_xml(LINKS, joint("j1", "base_link", "c")),
        "<joint name=\"j1\">: unknown child link 'c'",
    ),
    "joint cycle": (
        robot_xml(
            LINKS,
            joint("j1", "base_link", "a") + joint("j2", "a", "b") + joint("j3", "b", "a"),
        ),
        "<joint name=\"j3\">: link 'a' already has the parent 'base_link'",
    ),
    "pure cycle": (
        robot_xml(
            '<link name="a"/><link name="b"/>', joint("j1", "a", "b") + joint("j2", "b", "a")
        ),
        "<joint>s: the joints form a cycle: ",
    ),
    "link without name": (
        robot_xml('<link name="base_link"/><link/>', ""),
        "<link>: missing required attribute 'name'",
    ),
    "joint without type": (
        robot_xml(LINKS, '<joint name="j1"><parent link="base_link"/><child link="a"/></joint>'),
        "<joint name=\"j1\">: missing required attribute 'type'",
    ),
    "joint without child": (
        robot_xml(LINKS, '<joint name="j1" type="fixed"><parent link="base_link"/></joint>'),
        '<joint name="j1">: missing <child link=...>',
    ),
    "revolute without limit": (
        robot_xml(LINKS, joint("j1", "base_link", "a", "revolute")),
        '<joint name="j1">: a revolute joint needs <limit',
    ),
    "unknown joint type": (
        robot_xml(LINKS, joint("j1", "base_link", "a", "hinge")),
        "<joint name=\"j1\">: unknown type 'hinge'",
    ),
    "bad origin": (
        robot_xml(LINKS, joint("j1", "base_link", "a", extra='<origin xyz="0 0"/>')),
        "<joint name=\"j1\"> <origin>: attribute xyz='0 0' must be 3 numbers",
    ),
    "disconnected link": (
        robot_xml(LINKS, joint("j1", "base_link", "a")),
        "<robot>: the links must form one tree, but 2 links have no parent joint: base_link, b",
    ),
    "missing mesh file": (
        robot_xml(
            '<link name="base_link"><visual><geometry><mesh filename="meshes/nope.stl"/>'
            "</geometry></visual></link>",
            "",
        ),
        "<link name=\"base_link\"> <visual> <mesh>: mesh file 'meshes/nope.stl' not found",
    ),
    "box without size": (
        robot_xml('<link name="base_link"><visual><geometry><box/></geometry></visual></link>', ""),
        "<link name=\"base_link\"> <visual> <box>: missing required attribute 'size'",
    ),
    "not xml": ("<robot name='r'><link name='a'></robot>", "URDF: not well-formed XML"),
}


@pytest.mark.parametrize("case", MALFORMED)
def test_malformed_urdf_names_the_element_and_the_problem(case: str) -> None:
    xml, message = MALFORMED[case]
    with pytest.raises(URDFError) as error:
        urdf.load(xml)
    assert str(error.value).startswith(message), str(error.value)


def test_a_missing_file_is_reported() -> None:
    with pytest.raises(URDFError, match="file '/nonexistent/robot.urdf' not found"):
        urdf.load(Path("/nonexistent/robot.urdf"))
