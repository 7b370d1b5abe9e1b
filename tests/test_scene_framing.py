"""Recorded scenes are framed on what they show, describe it in words, and have a still.

The browser side (the robot in view at desktop and phone sizes) is in
tests/test_book_scenes.py; here the framing each scene carries is checked against the
robot's own geometry, and the still picture against the robot's colour.
"""

from __future__ import annotations

import io
import math
import threading

import numpy as np
import pytest
from PIL import Image

from rosbook import robots
from rosbook.book import stills as scene_stills
from rosbook.book.chromium import chromium_path
from rosbook.robots import urdf
from rosbook.sim.physics import DiffDriveSim, World
from rosbook.viz import scene as viz
from rosbook.viz import twin


def visual_points(
    robot: urdf.Robot, base: np.ndarray, positions: dict[str, float] | None = None
) -> np.ndarray:
    """Every vertex of every visual of ``robot`` placed at ``base``, in the world."""
    poses = robot.poses(positions or {})
    points = []
    for link in robot.model.robot.links:
        for visual in link.visuals:
            mesh = viz._visual_mesh(robot, visual)
            if mesh is not None:
                mesh.apply_transform(base @ poses[link.name])
                points.append(np.asarray(mesh.vertices))
    return np.concatenate(points)


def assert_inside(frame: dict, points: np.ndarray) -> None:
    distances = np.linalg.norm(points - np.asarray(frame["target"]), axis=1)
    assert distances.max() <= frame["radius"] + 1e-3, (distances.max(), frame)


@pytest.mark.parametrize("name", ["r2d2.urdf", "diff_drive.urdf"])
def test_a_robots_scene_is_framed_on_the_whole_robot(name: str) -> None:
    robot = urdf.load(robots.FOLDER / name)
    scene = viz.show(robot, camera=(0.9, 0.7, 0.5))
    lifted = viz.planar_pose(0.0, 0.0, 0.0, -viz.lowest_point(robot))
    points = visual_points(robot, lifted)
    assert_inside(scene.frame, points)
    # tight: the sphere is the box around the robot, not the whole floor
    assert scene.frame["radius"] <= np.linalg.norm(points.max(0) - points.min(0)) / 2 + 1e-3
    assert np.linalg.norm(scene.frame["direction"]) == pytest.approx(1.0, abs=1e-3)
    assert np.dot(scene.frame["direction"], [0.9, 0.7, 0.5]) == pytest.approx(
        np.linalg.norm([0.9, 0.7, 0.5]), abs=1e-3
    )


def test_a_recorded_drive_is_framed_on_its_world_and_every_pose_it_passes() -> None:
    sim = DiffDriveSim(World(arena=(-1.0, -1.0, 4.0, 2.0)))
    for v, w, seconds in [(0.4, 0.0, 4.0), (0.3, 0.8, 3.0)]:
        sim.command(v, w)
        sim.run(seconds)
    scene = twin.record(sim, fps=10)
    bot = robots.diff_drive()
    height = -viz.lowest_point(bot)
    for frame in sim.twin_frames(0.1):
        assert_inside(
            scene.frame, visual_points(bot, viz.planar_pose(frame.x, frame.y, frame.yaw, height))
        )
    for corner in [(-1.0, -1.0), (4.0, 2.0), (-1.0, 2.0), (4.0, -1.0)]:
        assert_inside(scene.frame, np.array([[*corner, 0.0]]))


def test_a_scene_says_what_it_shows() -> None:
    still = viz.show(robots.diff_drive())
    assert still.description == (
        "3D view of the robot bot (5 links: base_link, caster, laser_frame, left_wheel, "
        "right_wheel), on MeshCat's floor grid."
    )
    moving = twin.record(DiffDriveSim(World(arena=(-2.0, -2.0, 2.0, 2.0))), fps=5)
    assert moving.description.startswith("Animated 3D view of the robot bot")
    assert moving.description.endswith("and the world, on MeshCat's floor grid.")
    assert viz.Scene([], description="A box.").description == "A box."


def test_the_scene_box_carries_its_framing_and_description_for_the_player() -> None:
    scene = viz.show(robots.diff_drive())
    (found,) = scene_stills.scenes_in(scene.shared_html())
    assert found.description == scene.description
    assert 'role="img"' in found.html and "data-frame=" in found.html


def test_a_still_goes_inside_the_scene_box_and_in_print() -> None:
    (found,) = scene_stills.scenes_in(viz.show(robots.diff_drive()).shared_html())
    marked = scene_stills.with_still(found, "../_static/scenes/x.png")
    box_end = (
        marked.index("</div></div>")
        if "</div></div>" in marked
        else marked.index("</noscript></div>")
    )
    noscript = marked.index("<noscript>")
    assert noscript < box_end, "the still must be inside the scene's box"
    assert (
        f'<img class="{scene_stills.STILL_CLASS}" src="../_static/scenes/x.png" alt="3D view'
        in marked
    )
    assert f'<img class="{scene_stills.PRINT_CLASS}"' in marked
    words = scene_stills.with_still(found, None)
    assert "<img" not in words and found.description.replace("'", "&#x27;") in words


@pytest.mark.skipif(
    chromium_path() is None, reason="NO BROWSER: install Debian's chromium to draw stills"
)
# drives a browser (Chromium) like the book build: slow tier
@pytest.mark.slow
def test_the_still_camera_draws_the_robot_in_the_middle_of_its_picture() -> None:
    scene = viz.show(robots.diff_drive(), camera=(0.9, 0.7, 0.5), height=300)
    (found,) = scene_stills.scenes_in(scene.shared_html())
    drawn: dict[str, bytes] = {}

    def draw() -> None:
        with scene_stills.still_camera() as camera:
            drawn.update(camera.draw([found]))

    # In a thread of its own: the suite's session browser holds Playwright's loop in this
    # one, and a second sync Playwright refuses to start inside it.
    worker = threading.Thread(target=draw)
    worker.start()
    worker.join()
    png = drawn[found.id]
    pixels = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)
    assert pixels.shape[:2] == (300, scene_stills.STILL_WIDTH)
    # the base is yellow (255, 255, 0), lit: red and green high, blue low
    yellow = (pixels[..., 0] > 150) & (pixels[..., 1] > 150) & (pixels[..., 2] < 80)
    rows, cols = np.nonzero(yellow)
    assert len(rows) > 2000, "the robot's body is not in the picture"
    assert 0 < rows.min() and rows.max() < 299 and 0 < cols.min() and cols.max() < 719
    assert math.isclose(cols.mean(), 360, abs_tol=120) and math.isclose(
        rows.mean(), 150, abs_tol=90
    )
