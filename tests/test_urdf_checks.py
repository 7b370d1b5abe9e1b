"""rosbook.labs.lab04: each mistake in a lab robot gets its own explanation."""

from __future__ import annotations

from pathlib import Path

import pytest

from rosbook.labs import lab04 as urdf_checks
from rosbook.robots import DIFF_DRIVE_URDF

GOOD = DIFF_DRIVE_URDF.read_text()


def check_all(xml: str) -> None:
    robot = urdf_checks.load_student_urdf(xml)
    urdf_checks.assert_diff_drive_tree(robot)
    for wheel in ("left_wheel", "right_wheel"):
        urdf_checks.assert_rolls_forward(robot, wheel)
    urdf_checks.assert_diff_drive_dimensions(robot)


def test_the_lecture_robot_passes_every_check() -> None:
    check_all(GOOD)


MISTAKES = {
    "axis reversed": (
        ('<axis xyz="0 0 -1"/>', '<axis xyz="0 0 1"/>'),
        "rolls the robot backwards (-x)",
    ),
    "default axis": (
        ('<axis xyz="0 0 -1"/>', ""),
        "'left_wheel' turns about (1, 0, 0) (base_link frame) but its cylinder's axle points",
    ),
    "wheel not rolled": (
        (' rpy="1.570796 0 0"', ""),
        "'left_wheel' turns about (0, 0, -1) in base_link, but a wheel that rolls along x turns "
        "about base_link's y axis: it lies flat and spins like a turntable",
    ),
    "fixed wheel": (
        (
            'name="base_link_left_wheel" type="continuous"',
            'name="base_link_left_wheel" type="fixed"',
        ),
        "(base_link -> left_wheel) is 'fixed'; a wheel turns without limits",
    ),
    "swapped": (
        (
            '<parent link="base_link"/>\n    <child link="right_wheel"/>',
            '<parent link="right_wheel"/>\n    <child link="base_link"/>',
        ),
        "has parent 'right_wheel' and child 'base_link': parent and child are swapped",
    ),
    "missing caster": (('<child link="caster"/>', '<child link="castor"/>'), "not a valid URDF"),
    "laser misplaced": (
        ('<origin xyz="0 0 0.11"/>', '<origin xyz="0 0 0.6"/>'),
        "laser_frame is at",
    ),
    "laser moving": (
        ('name="base_link_laser" type="fixed"', 'name="base_link_laser" type="continuous"'),
        "(base_link -> laser_frame) is 'continuous'; the lab's laser_frame is attached",
    ),
    "wheels exchanged": (
        ('<origin xyz="0 0.2 0"', '<origin xyz="0 -0.2 0"'),
        "(left is +y, right is -y)",
    ),
    "box centred on base_link": (
        ('      <origin xyz="-0.2 0 0.05"/>\n', ""),
        "base_link's box is centred at (0, 0, 0) in base_link, expected (-0.2, 0, 0.05) (give "
        "its <visual> an <origin xyz>); base_link is the middle of the wheel axle",
    ),
    "wheels placed from the box's centre": (
        ('<origin xyz="0 0.2 0" rpy', '<origin xyz="0.2 0.2 -0.05" rpy'),
        "'left_wheel''s centre is at (0.2, 0.2, -0.05) in base_link, expected (0, 0.2, 0); "
        "base_link is the middle of the wheel axle",
    ),
    "small wheels": (('radius="0.04" length="0.05"', 'radius="0.03" length="0.05"'), "radius 0.03"),
    "caster floating": (('<sphere radius="0.04"/>', '<sphere radius="0.02"/>'), "would not stand"),
    "not a string": (None, "must be a string holding your URDF"),
}


@pytest.mark.parametrize("mistake", MISTAKES)
def test_each_mistake_is_explained(mistake: str) -> None:
    change, message = MISTAKES[mistake]
    xml = None if change is None else GOOD.replace(*change)
    assert xml != GOOD
    with pytest.raises(AssertionError) as error:
        check_all(xml)  # type: ignore[arg-type]
    assert message in str(error.value), str(error.value)


def test_a_students_urdf_is_text_never_a_path_to_a_file(tmp_path: Path) -> None:
    """urdf.load reads a string not starting with "<" as a path (a .xacro one through
    xacro): the check takes the student's value as text only."""
    named = tmp_path / "<robot.urdf.xacro"
    named.write_text(DIFF_DRIVE_URDF.read_text())
    with pytest.raises(AssertionError, match="must be a string holding your URDF"):
        urdf_checks.load_student_urdf(str(named))


def test_an_arm_check_names_numpy_angles_as_plain_numbers() -> None:
    """The hidden angles are numpy numbers: the message (and the student's function,
    also when it is a handle into the student's kernel) gets Python floats."""
    import numpy as np

    seen: list[tuple[type, ...]] = []

    def wrong(q1: float, q2: float) -> tuple[float, float, float]:
        seen.append((type(q1), type(q2)))
        return (0.0, 0.0, 0.0)

    with pytest.raises(AssertionError) as failed:
        urdf_checks.assert_position("end_effector_position", wrong, tuple(np.array([0.3, 1.1])),
                                    (0.8, 0.0, 0.1))  # fmt: skip
    assert str(failed.value).startswith("end_effector_position(0.3, 1.1): expected (0.8, 0, 0.1)")
    assert seen == [(float, float)]


def test_when_graded_the_robots_picture_is_the_test_cells_output(tmp_path: Path) -> None:
    """In the judge, ``show_robot`` puts the picture of the URDF it checked into the
    verdict's outputs (the feedback shows it), not onto the judge's stdout."""
    from rosbook.labs import remote
    from rosbook.robots import urdf

    j = remote.Judgement(kernel=None, folder=tmp_path)  # type: ignore[arg-type] (never asked)
    with remote.judging_cell(j):
        urdf_checks.show_robot(urdf.load(GOOD), "your DIFF_DRIVE_URDF")
    assert [sorted(o["data"]) for o in j.outputs] == [["image/png", "text/plain"]]
