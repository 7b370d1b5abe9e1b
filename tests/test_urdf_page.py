"""The built URDF chapter: its MeshCat scenes are in the page, the viewer is shared."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from rosbook import robots
from rosbook.book import pages as bookpages
from rosbook.robots import DIFF_DRIVE_URDF, urdf
from rosbook.viz.scene import VIEWER_JS

CHAPTER = "book/urdf_digital_twin"
ROBOTS = robots.FOLDER  # the example robots ship with rosbook
#: The chapter's scenes: three build steps, the drive, r2d2, the burger, the xacro wheels.
SCENES = 7


@pytest.fixture(scope="module")
def html(built_book: Path) -> Path:
    """The whole book, built once per test run (tests/conftest.py)."""
    return built_book


@pytest.fixture(scope="module")
def page(html: Path) -> str:
    return (html / f"{CHAPTER}.html").read_text()


def test_the_page_loads_the_shared_viewer_once(html: Path, page: str) -> None:
    assert page.count('src="../_static/meshcat/main.min.js?v=') == 1
    shared = html / "_static" / "meshcat" / "main.min.js"
    assert shared.read_bytes() == VIEWER_JS.read_bytes()
    assert "main.min.js" not in (html / "book" / "intro.html").read_text(), (
        "a page without a scene must not load the viewer"
    )


def test_every_scene_is_embedded_with_the_robots_links(page: str) -> None:
    scenes = bookpages.scene_commands(page)
    assert len(scenes) == SCENES
    paths = [{c.get("path") for c in scene} for scene in scenes]
    shown = {
        "bot": urdf.load(DIFF_DRIVE_URDF).links,
        "visual": urdf.load(ROBOTS / "r2d2.urdf").links,
        "turtlebot3_burger": urdf.load(robots.TURTLEBOT_BURGER_URDF).links,
        "wheels": ["base_link", "left_wheel", "right_wheel"],  # the chapter's xacro robot
    }
    # The complete robots (scene 3 onwards) have a node for every link.
    for scene_paths in paths[2:]:
        name = next(n for n in shown if f"/meshcat/{n}" in scene_paths)
        missing = [link for link in shown[name] if f"/meshcat/{name}/{link}" not in scene_paths]
        assert not missing, (name, missing)
    animations = [c for scene in scenes for c in scene if c["type"] == "set_animation"]
    assert len(animations) == 2, "the drive and r2d2 are animated"


def test_page_weight_beyond_the_theme_is_under_2_mb(html: Path) -> None:
    weight = bookpages.page_weight(html / f"{CHAPTER}.html")
    theme = bookpages.page_weight(html / "book" / "intro.html")
    extra = weight.html + sum(v for k, v in weight.assets.items() if k not in theme.assets)
    assert extra < 2_000_000, (extra, weight)
    assert weight.html < 1_000_000, "a scene carries its commands only, not the viewer"


@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")
def test_the_inline_scene_scripts_are_valid_javascript(page: str, tmp_path: Path) -> None:
    scripts = re.findall(r"<script>(.*?)</script>", page, re.S)
    players = [s for s in scripts if "MeshCat.Viewer" in s]
    assert len(players) == SCENES
    for i, script in enumerate(players):
        path = tmp_path / f"player{i}.js"
        path.write_text(script)
        done = subprocess.run(["node", "--check", str(path)], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
