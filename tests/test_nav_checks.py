"""Lab 9's checks on local code (no grading): what they say of a wrong A* path, and
the world's own map that the follower's paths are planned on."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest

from rosbook.labs import lab09 as checks
from rosbook.labs.probes import CheckFailed
from rosbook.nav.grid import OCCUPIED
from rosbook.sim.physics import Box, Wall, World

GRID = checks.parse_grid(["....", ".##.", "...."])


def answering(path: object) -> Callable[..., object]:
    """A stand-in for the student's astar that returns ``path``."""
    return lambda grid, start, goal: path


def test_a_shortest_path_passes_and_none_is_right_when_the_goal_is_walled_off() -> None:
    checks.assert_astar(answering([(0, 0), (0, 1), (0, 2), (1, 3)]), GRID, (0, 0), (1, 3))
    walled = checks.parse_grid(["..#..", "..#.."])
    checks.assert_astar(answering(None), walled, (0, 0), (1, 4))


@pytest.mark.parametrize(
    ("path", "said"),
    [
        ([(1, 3), (0, 2), (0, 1), (0, 0)], "it runs backwards"),
        ([(0, 0), (0, 2), (1, 3)], "step 0 goes from (0, 0) to (0, 2), not to one of the 8"),
        ([(0, 0), (1, 1), (1, 2), (1, 3)], "goes through the blocked cell (1, 1)"),
        ([(0, 0), (0, 1), (0, 2), (0, 3), (1, 3)], "it makes no diagonal step"),
        (None, "returned None, but a path of cost 3.414 exists"),
        ("path", "expected a list of (row, col) cells or None"),
    ],
    ids=["reversed", "jump", "blocked", "four_neighbours", "none", "not_cells"],
)
def test_a_wrong_path_is_named(path: object, said: str) -> None:
    with pytest.raises(CheckFailed, match=said.replace("(", r"\(").replace(")", r"\)")):
        checks.assert_astar(answering(path), GRID, (0, 0), (1, 3))


def test_a_path_where_there_is_none_is_named() -> None:
    walled = checks.parse_grid(["..#..", "..#.."])
    with pytest.raises(CheckFailed, match="the goal is walled off: return None"):
        checks.assert_astar(answering([]), walled, (0, 0), (1, 4))


def test_a_grid_written_with_other_characters_is_refused() -> None:
    with pytest.raises(ValueError, match=r"grid row 1 has \['x'\]"):
        checks.parse_grid(["...", ".x."])


def test_the_worlds_map_has_its_walls_and_boxes_and_the_plan_goes_round_them() -> None:
    world = World(
        arena=(0.0, 0.0, 4.0, 2.0),
        walls=(Wall((2.0, 0.0), (2.0, 1.2), 0.05),),
        boxes=(Box((3.0, 1.0), (0.4, 0.4)),),
        start=(1.0, 0.5, 0.0),
    )
    grid, spec = checks.world_grid(world)

    def at(x: float, y: float) -> int:
        row, col = spec.cells(x, y)
        return int(grid[row, col])

    assert at(2.0, 0.6) == at(3.0, 1.0) == at(-0.05, 1.0) == OCCUPIED  # wall, box, arena
    assert at(1.0, 1.0) == at(2.0, 1.6) == 0
    path = checks.path_points(checks.plan_path(world, (3.0, 0.4)))
    assert path[0] == (1.0, 0.5) and path[-1] == (3.0, 0.4)
    at_wall = min(path, key=lambda p: abs(p[0] - 2.0))
    assert at_wall[1] > 1.2 + checks.ROBOT_RADIUS - spec.resolution  # above the wall's end
    assert all(math.dist(p, (3.0, 1.0)) > 0.2 + checks.ROBOT_RADIUS for p in path)
