"""Lab 4 graded end to end: the usual URDF mistakes get specific feedback."""

from __future__ import annotations

import html
from pathlib import Path

import nbformat
import pytest

from tests.labtools import (
    answered,
    grade,
    lab04_axis_wrong,
    replace_in_answer,
    status_and_score,
    submit,
    with_round_trip,
)
from tests.labtools import feedback as feedback_html

#: The whole lab graded as a class: minutes (`make test-fast` leaves it out).
pytestmark = pytest.mark.slow

LAB = "lab04_urdf"

NAIVE_SEPARATION = """def wheel_separation(urdf_string):
    robot = urdf.load(urdf_string)
    left = robot.model.joint_map[robot.parent_joint('left_wheel').name].origin[:3, 3]
    right = robot.model.joint_map[robot.parent_joint('right_wheel').name].origin[:3, 3]
    return float(np.linalg.norm(left - right))
"""


def joint_fixed() -> nbformat.NotebookNode:
    """The left wheel on a fixed joint, and a wheel separation from joint origins only."""
    fixes = replace_in_answer(
        LAB,
        "diff_drive_urdf",
        '<joint name="base_link_left_wheel" type="continuous">',
        '<joint name="base_link_left_wheel" type="fixed">',
    )
    fixes["wheel_separation"] = NAIVE_SEPARATION
    return answered(LAB, **fixes)


def parent_child_swapped() -> nbformat.NotebookNode:
    return answered(
        LAB,
        **replace_in_answer(
            LAB,
            "diff_drive_urdf",
            '<parent link="base_link"/>\n    <child link="left_wheel"/>',
            '<parent link="left_wheel"/>\n    <child link="base_link"/>',
        ),
    )


@pytest.fixture(scope="module")
def graded(
    tmp_path_factory: pytest.TempPathFactory, round_trip: tuple[dict, Path]
) -> tuple[dict, Path]:
    root = tmp_path_factory.mktemp("submissions")
    submit(root, "axis_wrong", LAB, lab04_axis_wrong())
    submit(root, "joint_fixed", LAB, joint_fixed())
    submit(root, "swapped", LAB, parent_child_swapped())
    out = tmp_path_factory.mktemp("out")
    rows = grade(root, out, assignment_id=LAB, workers=2, cell_timeout=30)
    return with_round_trip((rows, out), round_trip, LAB)


def feedback(out: Path, student: str, lab: str) -> str:
    """The feedback page's text with HTML entities decoded."""
    return html.unescape(feedback_html(out, student, lab))


def score(graded: tuple[dict, Path], student: str) -> tuple[str, str]:
    return status_and_score(graded, LAB, student)


def test_right_submission_scores_full_marks_and_shows_the_robot(graded) -> None:
    assert score(graded, "right") == ("ok", "10")
    page = feedback(graded[1], "right", LAB)
    assert page.count('src="data:image/png;base64,') >= 1, "the robot's picture is missing"
    assert len(page.encode()) < 1_000_000, "the feedback page should stay small"


def test_wrong_wheel_axis_is_reported_as_rolling_backwards(graded) -> None:
    assert score(graded, "axis_wrong") == ("ok", "3")  # only wheel_separation is right
    page = feedback(graded[1], "axis_wrong", LAB)
    assert "a positive rotation of 'base_link_left_wheel' rolls the robot backwards" in page
    assert "reverse the sign of its <axis xyz>" in page
    assert "expected (0.3, 0.5, 0.1), got (0, 0.8, 0.1)" in page


def test_fixed_wheel_joint_and_naive_separation_are_reported(graded) -> None:
    assert score(graded, "joint_fixed") == ("ok", "3")  # only the arm is right
    page = feedback(graded[1], "joint_fixed", LAB)
    assert "(base_link -> left_wheel) is 'fixed'; a wheel turns without limits" in page
    assert "wheel_separation of a robot whose wheels hang below a turned link" in page
    assert "expected 0.270000, got 0.176068" in page


def test_swapped_parent_and_child_are_named(graded) -> None:
    assert score(graded, "swapped") == ("ok", "6")
    page = feedback(graded[1], "swapped", LAB)
    assert "joint 'base_link_left_wheel' has parent 'left_wheel' and child 'base_link'" in page
    assert "parent and child are swapped" in page


def test_feedback_never_shows_hidden_tests(graded) -> None:
    for student in ("right", "axis_wrong", "joint_fixed", "swapped"):
        page = feedback(graded[1], student, LAB)
        assert "BEGIN HIDDEN TESTS" not in page
        assert "default_rng(404)" not in page
