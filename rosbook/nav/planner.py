"""A* on an occupancy grid, for a robot of a given radius.

Occupied cells are grown by the robot's radius (a cell is blocked when the robot's middle
there would touch something); unknown cells count as free, so the robot plans through
what it has not seen yet and plans again as the map fills in. Cells near an obstacle cost
more, so paths keep a margin where there is room. Moves go to the 8 neighbours.
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from rosbook.nav.grid import OCCUPIED, GridSpec

#: Extra cost of a step into a cell within the margin of an obstacle (per cell length).
NEAR_COST = 4.0
NEIGHBOURS = [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1) if (dr, dc) != (0, 0)]


class NoPath(ValueError):
    """No path joins the start and the goal on this grid."""


def dilate(mask: np.ndarray, cells: int) -> np.ndarray:
    """``mask`` grown by a disk of radius ``cells`` cells."""
    grown = mask.copy()
    height, width = mask.shape
    for dr in range(-cells, cells + 1):
        for dc in range(-cells, cells + 1):
            if (dr, dc) == (0, 0) or dr * dr + dc * dc > cells * cells:
                continue
            src = mask[max(0, -dr) : height - max(0, dr), max(0, -dc) : width - max(0, dc)]
            grown[max(0, dr) : height - max(0, -dr), max(0, dc) : width - max(0, -dc)] |= src
    return grown


def astar(
    blocked: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    extra: np.ndarray | None = None,
) -> list[tuple[int, int]]:
    """The cheapest 8-connected path of cells from ``start`` to ``goal`` (both included)
    avoiding ``blocked``; ``extra`` adds a cost for entering each cell. Raises ``NoPath``."""
    height, width = blocked.shape
    for name, (r, c) in (("start", start), ("goal", goal)):
        if not (0 <= r < height and 0 <= c < width):
            raise NoPath(f"the {name} {(r, c)} is outside the grid ({height} x {width} cells)")
        if blocked[r, c]:
            raise NoPath(f"the {name} {(r, c)} is blocked (too close to an obstacle)")

    def heuristic(cell: tuple[int, int]) -> float:  # octile distance: never overestimates
        dr, dc = abs(cell[0] - goal[0]), abs(cell[1] - goal[1])
        return max(dr, dc) + (math.sqrt(2) - 1) * min(dr, dc)

    best = {start: 0.0}
    came_from: dict[tuple[int, int], tuple[int, int]] = {}
    frontier = [(heuristic(start), 0.0, start)]
    while frontier:
        _, cost, cell = heapq.heappop(frontier)
        if cell == goal:
            path = [cell]
            while cell in came_from:
                cell = came_from[cell]
                path.append(cell)
            return path[::-1]
        if cost > best[cell]:
            continue  # a cheaper way here was found since
        for dr, dc in NEIGHBOURS:
            nxt = (cell[0] + dr, cell[1] + dc)
            if not (0 <= nxt[0] < height and 0 <= nxt[1] < width) or blocked[nxt]:
                continue
            step = math.hypot(dr, dc) * (1.0 + (extra[nxt] if extra is not None else 0.0))
            if cost + step < best.get(nxt, math.inf):
                best[nxt] = cost + step
                came_from[nxt] = cell
                heapq.heappush(frontier, (cost + step + heuristic(nxt), cost + step, nxt))
    raise NoPath(f"no path from {start} to {goal}: the goal is walled off")


def plan(
    grid: np.ndarray,
    spec: GridSpec,
    start: tuple[float, float],
    goal: tuple[float, float],
    radius: float,
    margin: float = 0.25,
) -> list[tuple[float, float]]:
    """A path of points (metres) from ``start`` to ``goal`` for a robot of ``radius``
    on the occupancy ``grid``, keeping ``margin`` more from obstacles where it can."""
    occupied = grid >= OCCUPIED
    blocked = dilate(occupied, math.ceil(radius / spec.resolution))
    near = dilate(occupied, math.ceil((radius + margin) / spec.resolution)) & ~blocked
    cells = astar(
        blocked,
        tuple(int(v) for v in spec.cells(np.array(start[0]), np.array(start[1]))),  # type: ignore[arg-type]
        tuple(int(v) for v in spec.cells(np.array(goal[0]), np.array(goal[1]))),  # type: ignore[arg-type]
        extra=near * NEAR_COST,
    )
    points = [spec.center(r, c) for r, c in cells]
    points[0], points[-1] = tuple(start), tuple(goal)  # type: ignore[assignment]
    return points
