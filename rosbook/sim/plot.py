"""Pictures of a simulated run: the world, the robot and its path (2D, matplotlib).

The book embeds them (the build draws them from the run it just did), lab feedback
shows them as small PNGs, and :func:`animate` replays a trajectory as an HTML/JS
animation, the 2D stand-in for the MeshCat twin.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence

import matplotlib.pyplot as plt
from matplotlib.animation import FuncAnimation
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Polygon

from rosbook.sim.physics import Pose, RobotGeometry, Trajectory, World


def _placed(pose: Pose, points: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    return [(pose.x + c * x - s * y, pose.y + s * x + c * y) for x, y in points]


class RobotPatch:
    """The robot seen from above: its base and its two wheels, movable to a new pose."""

    def __init__(self, ax: Axes, pose: Pose, color: str = "tab:orange", alpha: float = 0.8):
        g = RobotGeometry()
        self.shapes = [g.footprint(), g.wheel_box(+1), g.wheel_box(-1)]
        colors = [color, "0.15", "0.15"]
        self.patches = [
            Polygon(_placed(pose, shape), closed=True, fc=c, ec="k", alpha=alpha, lw=0.8)
            for shape, c in zip(self.shapes, colors)
        ]
        for patch in self.patches:
            ax.add_patch(patch)

    def move(self, pose: Pose) -> None:
        for patch, shape in zip(self.patches, self.shapes):
            patch.set_xy(_placed(pose, shape))


def draw_world(ax: Axes, world: World) -> None:
    """Walls and obstacles, filled grey."""
    for wall in world.all_walls():
        ax.add_patch(Polygon(wall.corners(), closed=True, color="0.35"))
    for box in world.boxes:
        ax.add_patch(Polygon(box.corners(), closed=True, color="0.55"))
    if world.arena is not None:
        x0, y0, x1, y1 = world.arena
        ax.set_xlim(x0 - 0.15, x1 + 0.15)
        ax.set_ylim(y0 - 0.15, y1 + 0.15)


def draw_robot(ax: Axes, pose: Pose, color: str = "tab:orange", alpha: float = 0.8) -> RobotPatch:
    return RobotPatch(ax, pose, color, alpha)


def plot_path(
    trajectory: Trajectory,
    world: World | None = None,
    *,
    title: str = "",
    goal: tuple[float, float] | None = None,
    marks: Sequence[tuple[float, float]] = (),
    ax: Axes | None = None,
    size: float = 4.0,
) -> Figure:
    """The path of base_link over the world, the robot at start (grey) and end (orange)."""
    if ax is None:
        fig, ax = plt.subplots(figsize=(size, size))
    else:
        fig = ax.figure  # type: ignore[assignment]
    if world is not None:
        draw_world(ax, world)
    ax.plot(trajectory.x, trajectory.y, color="tab:blue", linewidth=1.5, label="path")
    if len(trajectory):
        draw_robot(ax, Pose(trajectory.x[0], trajectory.y[0], trajectory.yaw[0]), "0.8", 0.6)
        draw_robot(ax, Pose(trajectory.x[-1], trajectory.y[-1], trajectory.yaw[-1]))
    for mx, my in marks:
        ax.plot(mx, my, "+", color="tab:red", markersize=10)
    if goal is not None:
        ax.plot(*goal, "*", color="tab:green", markersize=14, label="goal")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if title:
        ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def png(fig: Figure, dpi: int = 72) -> bytes:
    """The figure as PNG bytes (closed afterwards: nothing piles up in a kernel)."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    plt.close(fig)
    return buffer.getvalue()


def animate(
    trajectory: Trajectory,
    world: World | None = None,
    *,
    fps: float = 10.0,
    size: float = 4.0,
    dpi: int = 72,
) -> FuncAnimation:
    """The run replayed at ``fps`` frames per simulated second (``.to_jshtml()`` for HTML)."""
    frames = trajectory.sample(1.0 / fps)
    fig, ax = plt.subplots(figsize=(size, size), dpi=dpi)
    if world is not None:
        draw_world(ax, world)
    ax.plot(trajectory.x, trajectory.y, color="tab:blue", alpha=0.25, linewidth=1)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    first = Pose(frames.x[0], frames.y[0], frames.yaw[0])
    body = draw_robot(ax, first)
    (trail,) = ax.plot([], [], color="tab:blue", linewidth=1.5)
    label = ax.set_title("")

    def update(i: int) -> tuple:
        pose = Pose(frames.x[i], frames.y[i], frames.yaw[i])
        body.move(pose)
        trail.set_data(frames.x[: i + 1], frames.y[: i + 1])
        wheels = f"wheels L {frames.left[i]:6.1f} R {frames.right[i]:6.1f} rad"
        label.set_text(f"t = {frames.t[i]:4.1f} s   {wheels}")
        return (*body.patches, trail, label)

    anim = FuncAnimation(fig, update, frames=len(frames), interval=1000.0 / fps, blit=False)
    plt.close(fig)
    return anim
