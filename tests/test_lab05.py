"""Lab 5 graded end to end: fixture submissions for the usual driving mistakes, one batch."""

from __future__ import annotations

import base64
import html
import math
import re
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

from rosbook.book import pages as bookpages
from rosbook.viz import twin
from tests.labtools import (
    answered,
    feedback,
    grade_id,
    grade_lab,
    grade_rows,
    lab05_swapped,
    replace_in_answer,
    status_and_score,
    submit,
)
from tests.slowdown import slow_machine

#: The whole lab graded as a class: minutes (`make test-fast` leaves it out).
pytestmark = pytest.mark.slow

LAB = "lab05_diff_drive"

SLEEPING_SQUARE = """
class SquareDriver(Node):
    \"\"\"Open loop with sleeps: drive, sleep, turn, sleep (blocks the executor).\"\"\"

    def __init__(self, node_name='square_driver', side=1.0):
        super().__init__(node_name)
        self.side = side
        self.cmd_pub = self.create_publisher(Twist, 'cmd_vel', 10)
        self.odom_sub = self.create_subscription(Odometry, 'odom', self.on_odom, 10)
        self.timer = self.create_timer(0.02, self.on_timer)

    def on_odom(self, msg):
        pass

    def on_timer(self):
        import time
        cmd = Twist()
        cmd.linear.x = 0.2
        self.cmd_pub.publish(cmd)
        time.sleep(1.0)
"""


def fixtures() -> dict[str, object]:
    return {
        "right": answered(LAB),
        "swapped": lab05_swapped(),
        "diameter": answered(
            LAB,
            **replace_in_answer(LAB, "wheel_speeds", ") / wheel_radius", ") / (2 * wheel_radius)"),
        ),
        "oscillating": answered(
            LAB,
            **replace_in_answer(
                LAB,
                "go_to_pose",
                "cmd.angular.z = max(-1.2, min(1.2, 2.5 * error))",
                "cmd.angular.z = 1.2 if error > 0 else -1.2",
            ),
        ),
        "atan": answered(
            LAB,
            **replace_in_answer(LAB, "go_to_pose", "math.atan2(dy, dx)", "math.atan(dy / dx)"),
        ),
        "no_final_turn": answered(
            LAB,
            **replace_in_answer(LAB, "go_to_pose", "self.phase = 'turn'", "self.phase = 'done'"),
        ),
        "never_stops": answered(
            LAB, **replace_in_answer(LAB, "square_driver", "self.legs_done >= 8", "False")
        ),
        "sleeping": answered(LAB, square_driver=SLEEPING_SQUARE),
    }


@pytest.fixture(scope="module")
def graded(
    tmp_path_factory: pytest.TempPathFactory, round_trip: tuple[dict, Path]
) -> tuple[dict, Path]:
    return grade_lab(tmp_path_factory, round_trip, LAB, fixtures(), cell_timeout=40)


def score(graded: tuple[dict, Path], student: str) -> tuple[str, str]:
    return status_and_score(graded, LAB, student)


def page(graded: tuple[dict, Path], student: str) -> str:
    return feedback(graded[1], student, LAB)


def test_solution_scores_full_marks_and_its_feedback_shows_the_paths(graded) -> None:
    """The driving cells' figures are of the runs the judge judged: the kernel does not
    drive them again (each judged cell is deferred there and shows the judge's pass)."""
    assert score(graded, "right") == ("ok", "10")
    shown = page(graded, "right")
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', shown)
    # two runs of each driving check, visible and hidden (three for go_to_pose)
    assert len(images) >= 5
    assert all(base64.b64decode(img).startswith(b"\x89PNG") for img in images)
    assert shown.count("passed: the grader checked this cell on your code") == 3


def test_feedback_shows_the_go_to_pose_runs_3d_twin_once(graded) -> None:
    frames = re.findall(r'<iframe [^>]*srcdoc="([^"]*)"', page(graded, "right"))
    assert len(frames) == 1, "one recorded twin (with its own viewer copy) per feedback page"
    inner = html.unescape(frames[0])
    assert "MeshCat" in inner and len(inner) < 1_300_000
    (commands,) = bookpages.scene_commands(inner)
    assert any(c["type"] == "set_animation" for c in commands)
    end = twin.axle_pose(twin.final_poses(commands, "bot"))
    assert math.hypot(end.x - 1.5, end.y - 1.0) < 0.05, f"the twin ends at {end}, not the goal"


def test_swapped_wheels_are_named(graded) -> None:
    assert score(graded, "swapped") == ("ok", "8")
    assert "left and right are swapped" in page(graded, "swapped")
    assert "needs the RIGHT wheel faster" in page(graded, "swapped")


def test_radius_used_as_diameter_is_named(graded) -> None:
    assert score(graded, "diameter") == ("ok", "8")
    assert "Is the wheel radius used as a diameter" in page(graded, "diameter")


def test_oscillating_controller_is_named(graded) -> None:
    assert score(graded, "oscillating") == ("ok", "6")
    text = page(graded, "oscillating")
    assert "the controller oscillates" in text
    assert re.search(r"the turn rate changed direction \d+ times", text)
    # the judge's figure of the run that failed comes before its verdict
    assert text.rindex("data:image/png") < text.index("the controller oscillates")


def test_node_that_never_stops_fails_in_bounded_time(graded) -> None:
    assert score(graded, "never_stops") == ("ok", "6")
    text = page(graded, "never_stops")
    assert "the robot was still moving in the last 2 s of the 35 s run" in text
    assert "the node never stops" in text


def test_atan_instead_of_atan2_is_named_not_blamed_on_speed(graded) -> None:
    assert score(graded, "atan") == ("ok", "6")
    text = page(graded, "atan")
    assert "after driving AWAY from the goal" in text
    assert "math.atan2(dy, dx) gives the full circle" in text
    assert "slow down and stop in time" not in text


def test_a_copy_of_the_chapters_go_to_goal_misses_the_final_heading(graded) -> None:
    assert score(graded, "no_final_turn") == ("ok", "6")
    text = page(graded, "no_final_turn")
    assert "from the goal heading" in text
    assert "Is the final turn missing?" in text


def test_blocking_callback_is_a_timeout_never_a_wrong_answer(graded) -> None:
    """A callback that sleeps makes the run slow in wall time: the judge's guard stops
    its check and the feedback says so, with what the judge waited for, as what it is
    (not as a cell the kernel interrupted); the other cells keep their points."""
    assert score(graded, "sleeping") == ("timeout", "6")
    text = page(graded, "sleeping")
    assert "ran out of time before it could decide" in text
    assert "test_square_driver (timeout: " in text
    assert "too slow" not in text


def test_a_blocking_drive_is_given_the_cells_limit_once(graded) -> None:
    """The judge's drive is given no longer than the grader's limit on a cell (40 s
    here, not its own 90 s), and the test cell whose check timed out in the judge is
    not run again in the kernel, where it would only wait out the limit once more."""
    text = html.unescape(page(graded, "sleeping"))
    assert "took longer than 40 s of wall time" in text, text[-3000:]
    autograded = graded[1] / "autograded" / "sleeping" / LAB / f"{LAB}.ipynb"
    cell = next(
        c
        for c in nbformat.read(autograded, as_version=4).cells
        if grade_id(c) == "test_square_driver"
    )
    assert [o.get("ename") for o in cell.outputs if o.output_type == "error"] == ["CheckFailed"], (
        cell.outputs
    )


def test_solution_scores_full_marks_on_a_slow_machine(tmp_path: Path) -> None:
    """No wall-clock limit of the checks decides a verdict: graded with the documented
    command on a slow machine (everything the grader starts held to a quarter of one core,
    tests/slowdown.py), the solution still scores full marks."""
    submissions, out = tmp_path / "submissions", tmp_path / "out"
    submit(submissions, "slowed", LAB, answered(LAB))
    with slow_machine() as inside:
        done = subprocess.run(
            [sys.executable, "-m", "autograder", "grade", str(submissions), "--assignment", LAB,
             "--workers", "1", "--timeout", "600", "--out", str(out)],
            preexec_fn=inside, capture_output=True, text=True, timeout=3600, check=False,
        )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    rows = grade_rows(out)
    assert (rows[("slowed", LAB)]["status"], rows[("slowed", LAB)]["score"]) == ("ok", "10")


def test_feedback_never_shows_hidden_tests(graded) -> None:
    for student in fixtures():
        text = page(graded, student)
        assert "BEGIN HIDDEN TESTS" not in text
        assert "square_b" not in text or student == "right"
