"""Checks that lab 9's test cells run: a student's A* and path follower.

``assert_astar`` calls the student's planner on a small grid (in the kernel when graded)
and compares the path it returns with the cost of the shortest one
(``rosbook.nav.planner.astar``). The follower drives the judge's simulator in lockstep
(lab 5's ``drive``) along a path the reference planner made on the world's own map
(``plan_path``), in rooms the student has not seen; a run is scored on arrival within a
tolerance, no collision and the simulated seconds it took. A run against a box that is
not on the map (``Halt``) checks that the follower stops for what its lidar sees.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from rosbook.labs import lab05
from rosbook.labs.deferral import deferrable
from rosbook.labs.probes import CheckFailed
from rosbook.labs.remote import is_student
from rosbook.nav.grid import OCCUPIED, GridSpec
from rosbook.nav.planner import NoPath, astar
from rosbook.nav.planner import plan as reference_plan
from rosbook.sim.node import SimulatedRobot
from rosbook.sim.physics import Box, World

#: What the graded runs show figures with (lab 5's).
PRELOAD = lab05.PRELOAD
#: The characters of a grid written as text (``parse_grid``): free and blocked.
FREE_CHAR, BLOCKED_CHAR = ".", "#"
#: Cell size of the map ``plan_path`` plans on (metres), and the margin around the arena.
MAP_RESOLUTION = 0.05
MAP_MARGIN = 0.5
#: The radius the reference planner keeps the robot's middle from anything (metres).
ROBOT_RADIUS = 0.35
#: The drive's ``Finish``, the run's helpers and checks, shared with lab 5.
Finish = lab05.Finish
drive = lab05.drive
show_path = lab05.show_path
assert_no_collision = lab05.assert_no_collision
assert_stopped = lab05.assert_stopped


# -- A* on a grid ----------------------------------------------------------------------


def parse_grid(rows: Sequence[str]) -> list[list[int]]:
    """A grid written as text, one string per row (``.`` free, ``#`` blocked), as the
    list of rows of 0 (free) and 1 (blocked) that ``astar`` takes."""
    grid = []
    for r, row in enumerate(rows):
        bad = set(row) - {FREE_CHAR, BLOCKED_CHAR}
        if bad:
            raise ValueError(f"grid row {r} has {sorted(bad)}: only '.' and '#' are allowed")
        grid.append([int(ch == BLOCKED_CHAR) for ch in row])
    if len({len(row) for row in grid}) != 1:
        raise ValueError("the grid's rows are not all as long")
    return grid


def path_cost(cells: Sequence[tuple[int, int]]) -> float:
    """Length of a path of cells: 1 a straight step, sqrt(2) a diagonal one."""
    return float(sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(cells[:-1], cells[1:])))


def shortest_cost(
    grid: Sequence[Sequence[int]], start: tuple[int, int], goal: tuple[int, int]
) -> float | None:
    """The cost of the shortest 8-connected path (``None`` if there is none)."""
    try:
        return path_cost(astar(np.asarray(grid, dtype=bool), start, goal))
    except NoPath:
        return None


def _cells(got: Any, call: str) -> list[tuple[int, int]]:
    try:
        cells = [(int(r), int(c)) for r, c in got]
    except (TypeError, ValueError):
        raise CheckFailed(
            f"{call} returned {got!r:.200}; expected a list of (row, col) cells or None"
        ) from None
    if not cells:
        raise CheckFailed(f"{call} returned an empty list; expected the cells from start to goal")
    return cells


def assert_astar(
    fn: Callable[..., Any],
    grid: Sequence[Sequence[int]],
    start: tuple[int, int],
    goal: tuple[int, int],
) -> None:
    """``fn(grid, start, goal)`` returns a shortest 8-connected path of free cells from
    ``start`` to ``goal`` (both included), or ``None`` when there is none."""
    start, goal = tuple(start), tuple(goal)  # type: ignore[assignment]
    call = f"astar(grid, {start}, {goal}) on a {len(grid)} x {len(grid[0])} grid"
    try:
        got = fn([list(row) for row in grid], start, goal)
    except Exception as exc:
        if is_student(fn):  # the judge's call says what the kernel raised, or timed out
            raise
        raise CheckFailed(f"{call} raised {type(exc).__name__}: {exc}") from None
    best = shortest_cost(grid, start, goal)
    if best is None:
        if got is not None:
            raise CheckFailed(
                f"{call} returned {got!r:.120} but the goal is walled off: return None "
                "when the frontier runs empty without reaching the goal"
            )
        return
    if got is None:
        raise CheckFailed(f"{call} returned None, but a path of cost {best:.3f} exists")
    cells = _cells(got, call)
    if cells[0] != start or cells[-1] != goal:
        hint = (
            ": it runs backwards; reverse the cells walked back from the goal"
            if cells[0] == goal and cells[-1] == start
            else ""
        )
        raise CheckFailed(
            f"{call} returned a path from {cells[0]} to {cells[-1]}; expected from the start "
            f"{start} to the goal {goal}, both included{hint}"
        )
    height, width = len(grid), len(grid[0])
    for i, (a, b) in enumerate(zip(cells[:-1], cells[1:])):
        if max(abs(b[0] - a[0]), abs(b[1] - a[1])) != 1:
            raise CheckFailed(
                f"{call}: step {i} goes from {a} to {b}, not to one of the 8 neighbours"
            )
    for cell in cells:
        r, c = cell
        if not (0 <= r < height and 0 <= c < width):
            raise CheckFailed(f"{call}: the path leaves the grid at {cell}")
        if grid[r][c]:
            raise CheckFailed(f"{call}: the path goes through the blocked cell {cell}")
    cost = path_cost(cells)
    if cost > best + 1e-6:
        diagonal = any(a[0] != b[0] and a[1] != b[1] for a, b in zip(cells[:-1], cells[1:]))
        hint = (
            "it makes no diagonal step: the 8 neighbours include the diagonals, at cost sqrt(2)"
            if not diagonal
            else "pop the cell with the lowest f = g + h, with a heuristic that never "
            "overestimates (the octile distance), and keep a cell's lowest g"
        )
        raise CheckFailed(
            f"{call} returned a path of cost {cost:.3f}; the shortest costs {best:.3f}: {hint}"
        )


# -- the follower ----------------------------------------------------------------------


def world_grid(world: World, resolution: float = MAP_RESOLUTION) -> tuple[np.ndarray, GridSpec]:
    """The world's own occupancy grid (what a finished map of it says): cells that a
    wall or a box covers are occupied, the rest free."""
    x0, y0, x1, y1 = world.arena or (-2.5, -2.5, 2.5, 2.5)
    spec = GridSpec.covering(
        (x0 - MAP_MARGIN, y0 - MAP_MARGIN, x1 + MAP_MARGIN, y1 + MAP_MARGIN), resolution
    )
    grid = np.zeros((spec.height, spec.width), dtype=np.int8)
    for shape in [w.corners() for w in world.all_walls()] + [b.corners() for b in world.boxes]:
        a, b, _, d = (np.asarray(p, dtype=float) for p in shape)
        steps = [max(2, int(np.linalg.norm(e) / (resolution / 2)) + 2) for e in (b - a, d - a)]
        u, v = np.meshgrid(np.linspace(0, 1, steps[0]), np.linspace(0, 1, steps[1]))
        points = a + u.ravel()[:, None] * (b - a) + v.ravel()[:, None] * (d - a)
        row, col = spec.cells(points[:, 0], points[:, 1])
        keep = spec.inside(row, col)
        grid[row[keep], col[keep]] = OCCUPIED
    return grid, spec


def plan_path(world: World, goal: tuple[float, float]) -> list[float]:
    """A path from the world's start to ``goal`` on its own map, by the reference planner,
    as the follower's ``path`` parameter takes it: ``[x0, y0, x1, y1, ...]``."""
    grid, spec = world_grid(world)
    points = reference_plan(grid, spec, world.start[:2], goal, ROBOT_RADIUS)
    return [float(v) for point in points for v in point]


def with_box(world: World, box: Box) -> World:
    """``world`` with ``box`` added: the world the robot drives in when its map (the
    path's) did not have the box."""
    return World(world.arena, world.walls, (*world.boxes, box), world.start)


def path_points(path: Sequence[float]) -> list[tuple[float, float]]:
    """The points of a flat ``path`` parameter, for a plot's marks."""
    return [(path[i], path[i + 1]) for i in range(0, len(path) - 1, 2)]


def reached_at(run: lab05.DriveRun, goal: tuple[float, float], tolerance: float) -> float | None:
    """The simulated time the robot first came within ``tolerance`` of ``goal``."""
    path = run.path
    near = np.nonzero(np.hypot(path[:, 1] - goal[0], path[:, 2] - goal[1]) <= tolerance)[0]
    return float(path[near[0], 0]) if near.size else None


def assert_arrived(
    run: lab05.DriveRun, goal: tuple[float, float], tolerance: float, limit: float
) -> None:
    """The run ends within ``tolerance`` of ``goal`` (the path's end), reached in at most
    ``limit`` simulated seconds."""
    path = run.path
    final = float(math.hypot(path[-1, 1] - goal[0], path[-1, 2] - goal[1]))
    when = reached_at(run, goal, tolerance)
    if when is not None and when > limit:
        raise CheckFailed(
            f"the robot reached the goal {goal} after {when:.1f} s of simulated time; the "
            f"limit is {limit:g} s. Drive at up to 0.3-0.4 m/s where the path is straight"
        )
    if final <= tolerance:
        return
    closest = float(np.min(np.hypot(path[:, 1] - goal[0], path[:, 2] - goal[1])))
    if when is not None:
        raise CheckFailed(
            f"the robot came within {closest:.2f} m of the goal {goal} but ended "
            f"{final:.2f} m away: stop (publish a zero Twist) once within {tolerance} m "
            "of the path's last point"
        )
    raise CheckFailed(
        f"the robot ended at ({path[-1, 1]:.2f}, {path[-1, 2]:.2f}), {final:.2f} m from the "
        f"goal {goal} after {run.seconds:.1f} s (closest {closest:.2f} m); expected within "
        f"{tolerance} m in at most {limit:g} s. Is the 'path' parameter read as "
        "[x0, y0, x1, y1, ...], and the heading error atan2(dy, dx) - yaw towards a point "
        "ahead on it?"
    )


@dataclass
class Halt:
    """A run's end when the robot stands still anywhere for ``still`` seconds after it
    moved, or collides (for ``drive(..., finish=Halt(...))``)."""

    still: float

    def until(self, sim: SimulatedRobot) -> Callable[[], bool]:
        """The condition for the simulated run: true once the verdict is known."""
        moved = [False, sim.now, sim.physics.pose]

        def known() -> bool:
            if sim.physics.collisions:
                return True
            pose = sim.physics.pose
            if (pose.x, pose.y, pose.yaw) != (moved[2].x, moved[2].y, moved[2].yaw):
                moved[:] = [True, sim.now, pose]
            return bool(moved[0]) and sim.now - moved[1] >= self.still

        return known


def assert_stopped_for(run: lab05.DriveRun, box: Box) -> None:
    """The robot stood still short of ``box`` (on its path, not on its map), untouched."""
    hits = run.sim.physics.collisions
    if hits:
        first = hits[0]
        raise CheckFailed(
            f"the robot hit the box at {box.center}, which was on its path but not on its "
            f"map, at t={first.t:.2f} s: watch 'scan' and stop (v = 0) when the lidar sees "
            "something close ahead (about 0.3 m within +-30 degrees of straight ahead)"
        )
    lab05.assert_stopped(run, last=1.0)


deferrable(globals())
