"""Lab 9 graded end to end: fixture submissions for the usual navigation mistakes, one
batch, and one that forges a pass in its kernel."""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

import pytest

from tests.labtools import (
    ATTACKS,
    answered,
    extra_cell,
    feedback,
    grade_id,
    grade_lab,
    hidden_only_lines,
    replace_in_answer,
    status_and_score,
)

#: The whole lab graded as a class: minutes (`make test-fast` leaves it out).
pytestmark = pytest.mark.slow

LAB = "lab09_navigation"


def forged() -> object:
    """The right answers, but every cell after the A* test cell runs as ``pass`` in the
    kernel (the follower is never defined there; its test cells look passed)."""
    notebook = answered(LAB)
    at = next(i for i, c in enumerate(notebook.cells) if grade_id(c) == "test_astar") + 1
    return extra_cell(notebook, ATTACKS["input_transformer"], at=at)


def fixtures() -> dict[str, object]:
    return {
        "right": answered(LAB),
        "four_neighbours": answered(
            LAB, **replace_in_answer(LAB, "astar", "if (dr, dc) == (0, 0) or", "if dr * dc or")
        ),
        "no_none": answered(LAB, **replace_in_answer(LAB, "astar", "return None", "return []")),
        "blind": answered(
            LAB, **replace_in_answer(LAB, "path_follower", "self.ahead = min(", "self.seen = min(")
        ),
        "slow": answered(
            LAB, **replace_in_answer(LAB, "path_follower", "SPEED = 0.3 ", "SPEED = 0.12")
        ),
        "forged": forged(),
    }


@pytest.fixture(scope="module")
def graded(
    tmp_path_factory: pytest.TempPathFactory, round_trip: tuple[dict, Path]
) -> tuple[dict, Path]:
    return grade_lab(tmp_path_factory, round_trip, LAB, fixtures(), cell_timeout=120)


def score(graded: tuple[dict, Path], student: str) -> tuple[str, str]:
    return status_and_score(graded, LAB, student)


def page(graded: tuple[dict, Path], student: str) -> str:
    return html.unescape(feedback(graded[1], student, LAB))


def test_solution_scores_full_marks_and_its_feedback_shows_the_runs(graded) -> None:
    """The follower's runs, visible and hidden, are the judge's: their path plots are in
    the feedback and each test cell passed there."""
    assert score(graded, "right") == ("ok", "10")
    shown = page(graded, "right")
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', shown)
    assert len(images) >= 4  # two runs of each driving check, visible and hidden
    assert all(base64.b64decode(img).startswith(b"\x89PNG") for img in images)
    assert shown.count("passed: the grader checked this cell on your code") == 3


def test_astar_without_diagonal_moves_is_named(graded) -> None:
    assert score(graded, "four_neighbours") == ("ok", "7")
    text = page(graded, "four_neighbours")
    assert re.search(r"returned a path of cost [\d.]+; the shortest costs [\d.]+", text)
    assert "it makes no diagonal step" in text


def test_astar_that_finds_a_path_through_a_wall_off_goal_is_named(graded) -> None:
    assert score(graded, "no_none") == ("ok", "7")
    assert "the goal is walled off: return None" in page(graded, "no_none")


def test_follower_blind_to_the_lidar_hits_the_box_not_on_its_map(graded) -> None:
    assert score(graded, "blind") == ("ok", "7")
    text = page(graded, "blind")
    assert "which was on its path but not on its map" in text
    assert "watch 'scan' and stop" in text


def test_slow_follower_fails_the_time_limit_in_simulated_seconds(graded) -> None:
    assert score(graded, "slow") == ("ok", "6")
    text = page(graded, "slow")
    assert re.search(
        r"reached the goal \(2\.3, 0\.8\) after [\d.]+ s of simulated time; the limit is 20 s", text
    )


def test_a_kernel_that_runs_cells_as_pass_scores_only_what_it_earned(graded) -> None:
    """The A* answer ran before the forgery and earns its points; every later cell ran
    as ``pass`` in the kernel, the judge's calls too: the judge reads no answer (never
    an earlier call's), finds no follower, and the cells that claimed a pass there are
    named; nothing more is scored."""
    assert score(graded, "forged") == ("tampered", "3")
    text = page(graded, "forged")
    assert text.count("passed: the grader checked this cell on your code") == 1
    assert "reported a pass in your notebook, but the grader's own check" in text
    assert "the judge failed" not in text and "could not check" not in text


def test_feedback_never_shows_hidden_tests(graded) -> None:
    hidden = hidden_only_lines(LAB)
    assert hidden
    for student in fixtures():
        text = page(graded, student)
        assert "BEGIN HIDDEN TESTS" not in text
        assert all(line not in text for line in hidden), student
