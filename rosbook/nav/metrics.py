"""What a navigation run measured: how far the robot drove and how close it came to
anything, from the simulator's own record of the run (not from what the nodes thought)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rosbook.sim.physics import RobotGeometry, Trajectory, World


def polyline_length(points: Sequence[tuple[float, float]]) -> float:
    """Metres along the points, in order."""
    xy = np.asarray(points, dtype=float).reshape(-1, 2)
    return float(np.sum(np.hypot(np.diff(xy[:, 0]), np.diff(xy[:, 1]))))


def path_length(trajectory: Trajectory) -> float:
    """Metres driven by base_link along ``trajectory``."""
    return polyline_length(list(zip(trajectory.x, trajectory.y)))


def _point_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances between points ``p`` (N, 2) and segments ``a``-``b`` (M, 2): (N, M)."""
    ab = b - a
    ap = p[:, None, :] - a[None, :, :]
    t = np.clip(np.sum(ap * ab, axis=2) / np.maximum(np.sum(ab * ab, axis=1), 1e-12), 0, 1)
    closest = a[None, :, :] + t[..., None] * ab[None, :, :]
    return np.linalg.norm(p[:, None, :] - closest, axis=2)


def _edges(polygons: list[list[tuple[float, float]]]) -> tuple[np.ndarray, np.ndarray]:
    starts = [corner for poly in polygons for corner in poly]
    ends = [poly[(i + 1) % len(poly)] for poly in polygons for i in range(len(poly))]
    return np.array(starts, dtype=float), np.array(ends, dtype=float)


def clearance(
    world: World,
    trajectory: Trajectory,
    geometry: RobotGeometry | None = None,
    period: float = 0.05,
) -> float:
    """The closest the robot's outline came to a wall or a box (metres), over the run
    sampled every ``period`` simulated seconds; 0 where they touched."""
    geometry = geometry or RobotGeometry()
    obstacles = [w.corners() for w in world.all_walls()] + [b.corners() for b in world.boxes]
    oa, ob = _edges(obstacles)
    shape = np.array(geometry.footprint(), dtype=float)
    nearest = np.inf
    sampled = trajectory.sample(period)
    for x, y, yaw in zip(sampled.x, sampled.y, sampled.yaw):
        c, s = np.cos(yaw), np.sin(yaw)
        outline = shape @ np.array([[c, s], [-s, c]]) + [x, y]
        ra, rb = _edges([[tuple(p) for p in outline]])
        d = min(
            _point_segment(outline, oa, ob).min(),
            _point_segment(np.vstack([oa]), ra, rb).min(),
        )
        nearest = min(nearest, float(d))
    return nearest
