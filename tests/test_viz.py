"""rosbook.viz: URDF visuals drawn in MeshCat, moved by joints and base pose, recorded."""

from __future__ import annotations

import base64
import json
import math
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import umsgpack

from rosbook import robots
from rosbook.robots import DIFF_DRIVE_URDF, urdf
from rosbook.viz import scene as viz

ROBOTS = robots.FOLDER  # the example robots ship with rosbook


@pytest.fixture(scope="module")
def bot() -> urdf.Robot:
    return urdf.load(DIFF_DRIVE_URDF)


def last(commands: list[dict[str, Any]], kind: str, path: str) -> dict[str, Any]:
    found = [c for c in commands if c["type"] == kind and c.get("path") == path]
    assert found, f"no {kind} on {path}"
    return found[-1]


def matrix(command: dict[str, Any]) -> np.ndarray:
    """MeshCat sends matrices column-major."""
    return np.array(command["matrix"], dtype=float).reshape(4, 4).T


def test_every_visual_is_drawn_with_its_shape_and_colour(bot: urdf.Robot) -> None:
    commands = viz.RobotView(bot).scene().commands
    shapes = {
        c["path"]: (c["object"]["geometries"][0]["type"], c["object"]["materials"][0]["color"])
        for c in commands
        if c["type"] == "set_object" and c["path"].endswith("visual_0")
    }
    assert shapes == {
        "/meshcat/bot/base_link/visual_0": ("BoxGeometry", 0xFFFF00),
        "/meshcat/bot/left_wheel/visual_0": ("CylinderGeometry", 0xFF0000),
        "/meshcat/bot/right_wheel/visual_0": ("CylinderGeometry", 0xFF0000),
        "/meshcat/bot/caster/visual_0": ("SphereGeometry", 0x808080),
        "/meshcat/bot/laser_frame/visual_0": ("CylinderGeometry", 0xFFFF00),
    }
    laser = last(commands, "set_object", "/meshcat/bot/laser_frame/visual_0")
    material = laser["object"]["materials"][0]
    assert material["opacity"] == 0.5 and material["transparent"] is True


def test_named_materials_are_looked_up_in_the_robot() -> None:
    r2d2 = urdf.load(ROBOTS / "r2d2.urdf")
    commands = viz.RobotView(r2d2).scene().commands
    base = last(commands, "set_object", "/meshcat/visual/base_link/visual_0")
    assert base["object"]["materials"][0]["color"] == 0x0000CC


SHARED_MATERIAL_URDF = """<robot name="shared">
  <link name="base">
    <visual><geometry><box size="1 1 1"/></geometry>
      <material name="orange"><color rgba="1 0.5 0 1"/></material></visual>
  </link>
  <link name="arm">
    <visual><geometry><box size="1 1 1"/></geometry><material name="orange"/></visual>
  </link>
  <joint name="j" type="fixed"><parent link="base"/><child link="arm"/></joint>
</robot>"""


def test_a_material_defined_in_one_link_colours_another_that_names_it() -> None:
    """As in ROS (urdfdom): <material name="orange"/> in 'arm' draws the orange of 'base'."""
    robot = urdf.load(SHARED_MATERIAL_URDF)
    commands = viz.RobotView(robot).scene().commands
    arm = last(commands, "set_object", "/meshcat/shared/arm/visual_0")
    assert arm["object"]["materials"][0]["color"] == 0xFF8000


def test_urdf_cylinders_along_z_are_drawn_along_z(bot: urdf.Robot) -> None:
    """three.js cylinders run along y: the drawn top (0, h/2, 0) must land on z = +h/2."""
    commands = viz.RobotView(bot).scene().commands
    height = last(commands, "set_object", "/meshcat/bot/laser_frame/visual_0")["object"][
        "geometries"
    ][0]["height"]
    placed = matrix(last(commands, "set_transform", "/meshcat/bot/laser_frame/visual_0"))
    np.testing.assert_allclose(placed @ [0, height / 2, 0, 1], [0, 0, height / 2, 1], atol=1e-12)
    # And the wheel, rolled by rpy (pi/2, 0, 0), has its axle along the base's y axis.
    link = matrix(last(commands, "set_transform", "/meshcat/bot/left_wheel"))
    wheel = matrix(last(commands, "set_transform", "/meshcat/bot/left_wheel/visual_0"))
    axle = (link @ wheel)[:3, :3] @ [0, 1, 0]
    np.testing.assert_allclose(np.abs(axle), [0, 1, 0], atol=1e-6)


def test_links_are_placed_by_forward_kinematics_and_follow_the_joints(bot: urdf.Robot) -> None:
    view = viz.RobotView(bot)
    view.set_joints({"base_link_left_wheel": 1.2})
    commands = view.scene().commands
    placed = matrix(last(commands, "set_transform", "/meshcat/bot/left_wheel"))
    np.testing.assert_allclose(placed, bot.pose("left_wheel", {"base_link_left_wheel": 1.2}))
    assert not np.allclose(placed, bot.pose("left_wheel"))


def test_base_pose_moves_the_whole_robot(bot: urdf.Robot) -> None:
    view = viz.RobotView(bot, standing=False)
    view.set_base_pose(1.0, 2.0, math.pi / 2)
    placed = matrix(last(view.scene().commands, "set_transform", "/meshcat/bot"))
    np.testing.assert_allclose(placed @ [1, 0, 0, 1], [1.0, 3.0, 0, 1], atol=1e-12)


def test_a_standing_robot_rests_its_wheels_and_caster_on_the_floor(bot: urdf.Robot) -> None:
    assert viz.lowest_point(bot) == pytest.approx(-0.04, abs=1e-6)
    view = viz.RobotView(bot)
    view.set_base_pose(0.5, 0.0, 1.0)
    placed = matrix(last(view.scene().commands, "set_transform", "/meshcat/bot"))
    assert placed[2, 3] == pytest.approx(0.04, abs=1e-6), "base_link is r above the floor"


def test_frames_are_triads_that_can_be_hidden(bot: urdf.Robot) -> None:
    view = viz.RobotView(bot, frames=True)
    view.show_frames(False)
    commands = view.scene().commands
    for link in bot.links:
        triad = last(commands, "set_object", f"/meshcat/bot/{link}/frame")
        assert triad["object"]["object"]["type"] == "LineSegments"
        assert last(commands, "set_property", f"/meshcat/bot/{link}/frame")["value"] is False


def test_an_animation_has_a_track_for_every_link_and_the_base(bot: urdf.Robot) -> None:
    view = viz.RobotView(bot)
    frames = [({"base_link_left_wheel": 0.1 * k}, (0.01 * k, 0.0, 0.0)) for k in range(10)]
    view.animate(frames, fps=10)
    animation = [c for c in view.scene().commands if c["type"] == "set_animation"][-1]
    paths = {a["path"] for a in animation["animations"]}
    assert paths == {"/meshcat/bot"} | {f"/meshcat/bot/{link}" for link in bot.links}
    clip = next(a["clip"] for a in animation["animations"] if a["path"] == "/meshcat/bot")
    position = next(t for t in clip["tracks"] if t["name"] == ".position")
    assert [k["time"] for k in position["keys"]] == list(range(10))
    assert position["keys"][-1]["value"] == pytest.approx([0.09, 0.0, 0.04])  # standing


@pytest.mark.parametrize(
    "path",
    [ROBOTS / "r2d2.urdf", robots.TURTLEBOT_BURGER_URDF, DIFF_DRIVE_URDF],
    ids=["r2d2", "turtlebot_burger", "diff_drive"],
)
def test_exported_scene_contains_every_link(path: Path) -> None:
    robot = urdf.load(path)
    scene = viz.show(robot)
    for link in robot.links:
        assert f"/meshcat/{robot.name}/{link}" in scene.paths, link
    page = scene.shared_html()
    payload = re.search(r'<script type="application/json" id="[^"]+">(.*?)</script>', page, re.S)
    assert payload is not None
    replayed = [umsgpack.unpackb(base64.b64decode(b)) for b in json.loads(payload.group(1))]
    assert replayed == scene.commands
    assert viz.SCENE_CLASS in page and "MeshCat.Viewer" in page
    assert "main.min.js" not in page, "the viewer script is shared, not inlined"


def test_meshes_are_drawn_as_triangles_scaled_by_the_urdf() -> None:
    burger = urdf.load(robots.TURTLEBOT_BURGER_URDF)
    commands = viz.RobotView(burger).scene().commands
    lds = last(commands, "set_object", "/meshcat/turtlebot3_burger/base_scan/visual_0")
    geometry = lds["object"]["geometries"][0]
    assert geometry["type"] == "BufferGeometry"
    position = geometry["data"]["attributes"]["position"]
    vertices = np.frombuffer(position["array"].data, dtype=np.float32).reshape(-1, 3)
    # lds.stl is a cylinder of radius 35 mm; the URDF scales it by 0.001.
    assert np.abs(vertices[:, :2]).max() == pytest.approx(0.035, rel=1e-3)


def test_live_view_server_is_stopped_by_close_live(bot: urdf.Robot) -> None:
    vis = viz.live_visualizer()
    proc = vis.window.server_proc
    try:
        viz.RobotView(bot, vis=vis)
        assert len(vis.static_html()) > 100_000, "the server should serve the scene"
    finally:
        viz.close_live(vis)
    assert proc.poll() is not None, "the MeshCat server process is still running"


def test_scene_needs_a_recording_view(bot: urdf.Robot) -> None:
    class Window:
        def send(self, command: Any) -> None:
            pass

    import meshcat

    view = viz.RobotView(bot, vis=meshcat.Visualizer(window=Window()))
    with pytest.raises(TypeError, match="recording view"):
        view.scene()


def test_sketch_is_a_small_png_showing_the_robots_colours(bot: urdf.Robot) -> None:
    import io

    from matplotlib.image import imread

    png = viz.sketch(bot, title="bot")
    assert png.startswith(b"\x89PNG") and len(png) < 60_000
    pixels = imread(io.BytesIO(png))[:, :, :3]
    red = (pixels[:, :, 0] > 0.9) & (pixels[:, :, 1] < 0.2) & (pixels[:, :, 2] < 0.2)
    yellow = (pixels[:, :, 0] > 0.9) & (pixels[:, :, 1] > 0.9) & (pixels[:, :, 2] < 0.2)
    assert red.sum() > 100, "the red wheels are not drawn"
    assert yellow.sum() > 1000, "the yellow base is not drawn"


def _ended(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split()[2] in ("Z", "X")
    except FileNotFoundError:
        return True


@pytest.mark.skipif(sys.platform != "linux", reason="PR_SET_PDEATHSIG is Linux only")
# starts a MeshCat server in a kernel of its own: slow tier
@pytest.mark.slow
def test_live_server_ends_when_its_kernel_is_killed() -> None:
    script = (
        "from rosbook import viz\n"
        "vis = viz.live_visualizer()\n"
        "print(vis.window.server_proc.pid, flush=True)\n"
        "import time; time.sleep(30)\n"
    )
    kernel = subprocess.Popen(
        [sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, cwd=Path.cwd()
    )
    try:
        assert kernel.stdout is not None
        lines = [kernel.stdout.readline() for _ in range(3)]
        server = int(next(line for line in lines if line.strip().isdigit()))
        assert not _ended(server)
    finally:
        kernel.kill()
        kernel.wait()
    deadline = time.monotonic() + 60  # a guard: the kernel reports the death at once
    while not _ended(server) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert _ended(server), "the MeshCat server outlived its killed kernel"


def test_a_scene_exports_as_a_standalone_page_loading_a_given_viewer(bot: urdf.Robot) -> None:
    page = viz.show(bot).standalone_html("meshcat/main.min.js")
    assert page.startswith("<!DOCTYPE html>")
    assert page.count("<script src='meshcat/main.min.js'></script>") == 1
    assert viz.SCENE_CLASS in page and len(page) < 100_000


def test_outside_the_book_a_scene_carries_its_own_viewer(
    bot: urdf.Robot, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(viz.VIEWER_MODE_VARIABLE, raising=False)
    page = viz.show(bot)._repr_html_()
    assert page.startswith("<iframe title=") and "srcdoc=" in page and len(page) > VIEWER_SIZE
    assert 'title="3D view of the robot' in page  # a frame is named by what it shows
    monkeypatch.setenv(viz.VIEWER_MODE_VARIABLE, "shared")
    page = viz.show(bot)._repr_html_()
    assert page.startswith(f'<div class="{viz.SCENE_CLASS}"') and len(page) < 100_000


VIEWER_SIZE = viz.VIEWER_JS.stat().st_size


def test_moving_the_robot_many_times_does_not_grow_the_scene(bot: urdf.Robot) -> None:
    once = viz.RobotView(bot)
    once.set_joints({"base_link_left_wheel": 0.1})
    many = viz.RobotView(bot)
    for k in range(50):
        many.set_joints({"base_link_left_wheel": 0.1 * (k + 1)})
        many.set_base_pose(0.01 * k, 0.0, 0.0)
    assert len(many.scene().commands) == len(once.scene().commands)
    final = matrix(last(many.scene().commands, "set_transform", "/meshcat/bot/left_wheel"))
    np.testing.assert_allclose(final, bot.pose("left_wheel", {"base_link_left_wheel": 5.0}))


def test_compaction_keeps_each_object_before_its_transform(bot: urdf.Robot) -> None:
    view = viz.RobotView(bot)
    view.set_joints({"base_link_left_wheel": 1.0})
    view.show_frames(True)
    commands = view.scene().commands
    order = {(c["type"], c.get("path")): i for i, c in enumerate(commands)}
    for link in bot.links:
        frame = f"/meshcat/bot/{link}/frame"
        assert order[("set_object", frame)] < order[("set_property", frame)]
        visual = f"/meshcat/bot/{link}/visual_0"
        assert order[("set_object", visual)] < order[("set_transform", visual)]
    redrawn = viz.RobotView(bot, vis=view.vis)  # deletes the robot, then draws it anew
    assert len(redrawn.scene().commands) == len(viz.RobotView(bot).scene().commands)
