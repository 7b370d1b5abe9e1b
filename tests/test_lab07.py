"""Lab 7 graded end to end: wrong frames, stamps, rotations and lookups get specific
feedback, and a kernel that forges passes scores nothing."""

from __future__ import annotations

import html
from pathlib import Path

import nbformat
import pytest

from tests.labtools import answered, extra_cell, grade_lab, replace_in_answer
from tests.labtools import feedback as feedback_html

#: The whole lab graded as a class: minutes (`make test-fast` leaves it out).
pytestmark = pytest.mark.slow

LAB = "lab07_frames"

#: Every later cell of the kernel run as `pass`: the kernel's own test runs "pass".
FORGE = "get_ipython().input_transformers_post.append(lambda lines: ['pass\\n'])"


def changed(*changes: tuple[str, str, str]) -> nbformat.NotebookNode:
    """The solution with each (grade_id, old, new) replaced in that answer."""
    fixes: dict[str, str] = {}
    for gid, old, new in changes:
        if gid not in fixes:
            fixes.update(replace_in_answer(LAB, gid, old, new))
        else:
            assert old in fixes[gid], f"{old!r} not in the answer {gid}"
            fixes[gid] = fixes[gid].replace(old, new)
    return answered(LAB, **fixes)


#: The static transform's parent and child swapped; odometry sent in frame 'world'.
WRONG_FRAMES = (
    ("static_frame", "t.header.frame_id = parent", "t.header.frame_id = child"),
    ("static_frame", "t.child_frame_id = child", "t.child_frame_id = parent"),
    ("odom_broadcaster", "t.header.frame_id = msg.header.frame_id", "t.header.frame_id = 'world'"),
)

#: The static rotation by twice the yaw; odometry stamped with the node's clock.
WRONG_TIMES = (
    ("static_frame", "math.sin(yaw / 2.0)", "math.sin(yaw)"),
    ("static_frame", "math.cos(yaw / 2.0)", "math.cos(yaw)"),
    ("odom_broadcaster", "t.header.stamp = msg.header.stamp",
     "t.header.stamp = self.get_clock().now().to_msg()"),
)  # fmt: skip

#: Odometry always sent as odom -> base_link (the visible case's names); a lookup of the
#: target in the source, not the source in the target.
FIXED_NAMES = (
    ("odom_broadcaster", "t.header.frame_id = msg.header.frame_id", "t.header.frame_id = 'odom'"),
    ("odom_broadcaster", "t.child_frame_id = msg.child_frame_id", "t.child_frame_id = 'base_link'"),
    ("frame_locator", "lookup_transform(target_frame, source_frame, Time())",
     "lookup_transform(source_frame, target_frame, Time())"),
)  # fmt: skip


@pytest.fixture(scope="module")
def graded(
    tmp_path_factory: pytest.TempPathFactory, round_trip: tuple[dict, Path]
) -> tuple[dict, Path]:
    submissions = {
        "wrong_frames": changed(*WRONG_FRAMES),
        "wrong_times": changed(*WRONG_TIMES),
        "fixed_names": changed(*FIXED_NAMES),
        "forged": extra_cell(answered(LAB), FORGE),
    }
    return grade_lab(tmp_path_factory, round_trip, LAB, submissions, cell_timeout=120)


def feedback(out: Path, student: str) -> str:
    """The feedback page's text with HTML entities decoded."""
    return html.unescape(feedback_html(out, student, LAB))


def score(graded: tuple[dict, Path], student: str) -> tuple[str, float]:
    row = graded[0][(student, LAB)]
    return row["status"], float(row["score"])


def test_right_submission_scores_full_marks_and_untouched_zero(graded) -> None:
    assert score(graded, "right") == ("ok", 8.0)
    assert score(graded, "untouched") == ("ok", 0.0)


def test_swapped_static_frames_and_a_wrong_odometry_frame_are_named(graded) -> None:
    assert score(graded, "wrong_frames") == ("ok", 3.0)  # only the lookup is right
    page = feedback(graded[1], "wrong_frames")
    assert (
        "published no transform of frame 'base_link' on /tf_static (it sent base_link -> world)"
        in page
    )
    assert "published base_link in frame 'world', expected 'odom'" in page


def test_a_rotation_by_twice_the_yaw_and_the_callbacks_time_are_named(graded) -> None:
    assert score(graded, "wrong_times") == ("ok", 3.0)
    page = feedback(graded[1], "wrong_times")
    assert (
        "base_link in world on /tf_static: (x, y, yaw) = (1.000, 2.000, 1.000), "
        "expected (1.000, 2.000, 0.500)" in page
    )
    assert "expected the odometry's stamp 10 s (header.stamp of the /odom message)" in page


def test_hidden_frame_names_and_an_inverted_lookup_are_caught(graded) -> None:
    """Frames written in as the visible case names them pass it and fail the hidden one;
    a lookup the wrong way round gives the inverse pose."""
    assert score(graded, "fixed_names") == ("ok", 2.0)  # only the static frame is right
    page = feedback(graded[1], "fixed_names")
    assert "published no transform of frame 'rover' on /tf (it sent odom -> base_link)" in page
    assert (
        "where('earth', 'dock') (where dock is in earth): (x, y, yaw) = (-1.000, 2.000, -1.571), "
        "expected (2.000, 1.000, 1.571)" in page
    )


def test_a_kernel_that_forges_passes_scores_nothing(graded) -> None:
    """The kernel runs every cell after the forging one as `pass` (the answers too), so
    its test cells "pass" there; the judge's run of them scores nothing and says so."""
    assert score(graded, "forged") == ("tampered", 0.0)
    page = feedback(graded[1], "forged")
    assert "passed: the grader checked" not in page
    assert "reported a pass in your notebook, but the grader's own check" in page


def test_feedback_never_shows_hidden_tests(graded) -> None:
    for student in ("right", "wrong_frames", "wrong_times", "fixed_names"):
        page = feedback(graded[1], student)
        assert "BEGIN HIDDEN TESTS" not in page
        assert "charger_frame" not in page
