"""The built driving chapter: the recorded 3D twins of a drive are embedded in the page."""

from __future__ import annotations

from pathlib import Path

import pytest

from rosbook import robots
from rosbook.book import pages as bookpages
from rosbook.viz import twin

CHAPTER = "book/drive_robot"


@pytest.fixture(scope="module")
def page(built_book: Path) -> str:
    """The chapter from the whole book, built once per test run (tests/conftest.py)."""
    return (built_book / f"{CHAPTER}.html").read_text()


def test_the_page_embeds_animated_twins_with_the_robots_links(page: str) -> None:
    scenes = bookpages.scene_commands(page)
    assert len(scenes) == 2, "two recorded twins: the go-to-goal drive, and its bag replayed"
    bot = robots.diff_drive()
    for commands in scenes:
        paths = {c.get("path") for c in commands}
        missing = [link for link in bot.links if f"/meshcat/{bot.name}/{link}" not in paths]
        assert not missing, missing
        (animation,) = [c for c in commands if c["type"] == "set_animation"]
        animated = {a["path"] for a in animation["animations"]}
        assert {"/meshcat/bot", "/meshcat/bot/left_wheel", "/meshcat/bot/right_wheel"} <= animated
        assert any(p and p.startswith("/meshcat/world/box") for p in paths), "the obstacle"
        # the drive ends at the goal (2.0, 1.2), within the controller's 2 cm
        end = twin.axle_pose(twin.final_poses(commands, bot.name))
        assert abs(end.x - 2.0) < 0.02 and abs(end.y - 1.2) < 0.02, end


def test_the_twin_is_light_and_uses_the_shared_viewer(built_book: Path, page: str) -> None:
    assert page.count('src="../_static/meshcat/main.min.js?v=') == 1
    weight = bookpages.page_weight(built_book / f"{CHAPTER}.html")
    assert weight.html < 400_000, "the twin carries its commands only, not the viewer"
