"""An occupancy grid built from laser scans taken at known poses (mapping, not SLAM).

Each cell keeps the log-odds that it is occupied. A scan's ray lowers the log-odds of the
cells it crosses (it saw through them) and raises that of the cell it ended in (it hit
something there), unless the ray reached the lidar's maximum range (it hit nothing).
Cells no ray has touched stay unknown. ``occupancy()`` gives them as
``nav_msgs/msg/OccupancyGrid`` values: -1 unknown, 0 free, 100 occupied.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

#: Log-odds added for a hit, and for a ray passing through (one of either is enough to
#: call a cell occupied or free, a second one can change its state).
HIT = 0.9
MISS = -0.6
#: Log-odds are kept within these bounds, so a cell can change its mind.
CLAMP = 4.0
#: A cell counts as occupied above this log-odds, free below minus it.
THRESHOLD = 0.5
UNKNOWN, FREE, OCCUPIED = -1, 0, 100


@dataclass(frozen=True)
class GridSpec:
    """Where a grid lies: its lower-left corner (metres), cell size, and size in cells."""

    origin: tuple[float, float]
    resolution: float
    width: int
    height: int

    @classmethod
    def covering(
        cls, bounds: tuple[float, float, float, float], resolution: float = 0.05
    ) -> GridSpec:
        """The grid that covers ``bounds`` = (xmin, ymin, xmax, ymax)."""
        x0, y0, x1, y1 = bounds
        width = math.ceil(round((x1 - x0) / resolution, 9))
        height = math.ceil(round((y1 - y0) / resolution, 9))
        return cls((x0, y0), resolution, width, height)

    def cells(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Row and column of the points (x, y) (outside the grid too)."""
        col = np.floor((np.asarray(x) - self.origin[0]) / self.resolution).astype(int)
        row = np.floor((np.asarray(y) - self.origin[1]) / self.resolution).astype(int)
        return row, col

    def inside(self, row: np.ndarray, col: np.ndarray) -> np.ndarray:
        return (row >= 0) & (row < self.height) & (col >= 0) & (col < self.width)

    def center(self, row: int, col: int) -> tuple[float, float]:
        """The middle of a cell, in metres."""
        return (
            self.origin[0] + (col + 0.5) * self.resolution,
            self.origin[1] + (row + 0.5) * self.resolution,
        )


class OccupancyMapper:
    """Log-odds occupancy of a ``GridSpec``'s cells, from scans at known poses."""

    def __init__(self, spec: GridSpec) -> None:
        self.spec = spec
        self.log_odds = np.zeros((spec.height, spec.width))
        self.scans = 0

    def add_scan(
        self,
        pose: tuple[float, float, float],
        ranges: Any,
        angle_min: float,
        angle_increment: float,
        range_max: float,
    ) -> None:
        """Fold in one scan taken by a lidar at ``pose`` = (x, y, yaw)."""
        x, y, yaw = pose
        r = np.asarray(ranges, dtype=float)
        valid = np.isfinite(r)
        hit = valid & (r < range_max)
        reach = np.where(valid, np.minimum(r, range_max), 0.0)
        angles = yaw + angle_min + angle_increment * np.arange(len(r))
        step = self.spec.resolution / 2
        samples = np.arange(0.0, range_max, step)
        # Points along every ray, short of its end by half a cell (its end is the hit).
        along = samples[None, :] < (reach[:, None] - step)
        px = x + samples[None, :] * np.cos(angles)[:, None]
        py = y + samples[None, :] * np.sin(angles)[:, None]
        row, col = self.spec.cells(px[along], py[along])
        keep = self.spec.inside(row, col)
        free = np.zeros(self.log_odds.shape, dtype=bool)
        free[row[keep], col[keep]] = True
        hx = x + reach[hit] * np.cos(angles[hit])
        hy = y + reach[hit] * np.sin(angles[hit])
        row, col = self.spec.cells(hx, hy)
        keep = self.spec.inside(row, col)
        occupied = np.zeros(self.log_odds.shape, dtype=bool)
        occupied[row[keep], col[keep]] = True
        free &= ~occupied
        self.log_odds[free] += MISS
        self.log_odds[occupied] += HIT
        np.clip(self.log_odds, -CLAMP, CLAMP, out=self.log_odds)
        self.scans += 1

    def occupancy(self) -> np.ndarray:
        """The grid as int8 rows (row 0 at the bottom): -1 unknown, 0 free, 100 occupied."""
        grid = np.full(self.log_odds.shape, UNKNOWN, dtype=np.int8)
        grid[self.log_odds < -THRESHOLD] = FREE
        grid[self.log_odds > THRESHOLD] = OCCUPIED
        return grid


def to_msg(grid: np.ndarray, spec: GridSpec, stamp: Any, frame_id: str = "odom") -> Any:
    """A ``nav_msgs/msg/OccupancyGrid`` of ``grid`` (row-major, starting at the origin)."""
    from nav_msgs.msg import OccupancyGrid

    msg = OccupancyGrid()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.info.resolution = float(spec.resolution)
    msg.info.width = spec.width
    msg.info.height = spec.height
    msg.info.origin.position.x = float(spec.origin[0])
    msg.info.origin.position.y = float(spec.origin[1])
    msg.info.origin.orientation.w = 1.0
    msg.data = grid.astype(np.int8).ravel().tolist()
    return msg


def from_msg(msg: Any) -> tuple[np.ndarray, GridSpec]:
    """The grid and its spec back from a ``nav_msgs/msg/OccupancyGrid``."""
    info = msg.info
    spec = GridSpec(
        (info.origin.position.x, info.origin.position.y),
        round(info.resolution, 9),
        info.width,
        info.height,
    )
    grid = np.asarray(msg.data, dtype=np.int8).reshape(info.height, info.width)
    return grid, spec
