"""The built book's 3D scenes in a real browser (headless Chromium), at desktop and phone
sizes: the robot in view, an animation that plays, a drag that rotates the view, controls
that leave the view visible; a still picture without JavaScript and in print.

A file of its own, beside ``test_book_browser.py`` (every page), so that two test workers
drive a browser each: both files take minutes of rendering.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from rosbook.book import pages as bookpages
from rosbook.book.site import scene_ids, scroll_off_screen, visit, wait_for_first_frame
from rosbook.book.stills import PRINT_CLASS, STILL_CLASS
from tests.browser import SIZES, robots_in, scene_pages


def _box_png(page: object, scene: str) -> np.ndarray:
    png = page.locator(f"#{scene}").screenshot(type="png")
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def _viewer(scene: str) -> str:
    return f"document.getElementById('{scene}-pane').meshcatViewer"


def _still(page: object, scene: str, at: float) -> None:
    """Pause the scene's animation at fraction ``at`` of its length (0 the start, 1 the end)
    and redraw."""
    page.evaluate(
        f"() => {{ const v = {_viewer(scene)}; v.animator.pause();"
        f" v.animator.seek({at} * v.animator.duration); v.render(); }}"
    )


def visuals_in(built_book: Path, page: str) -> list[list[list[str]]]:
    """For each scene of ``page``, the scene-tree paths of its robots' visual geometry
    (the robot's body, not the frame triads drawn with it)."""
    return [
        sorted(
            {
                tuple(c["path"].strip("/").split("/"))
                for c in scene
                if "/visual_" in c.get("path", "")
            }
        )
        for scene in bookpages.scene_commands((built_book / page).read_text())
    ]


def _show_robots(page: object, scene: str, visuals: list[list[str]], visible: bool) -> None:
    paths = [list(path) for path in visuals]
    page.evaluate(
        f"() => {{ const v = {_viewer(scene)};"
        f" for (const p of {paths!r}) v.set_property(p, 'visible', {str(visible).lower()});"
        " v.render(); }"
    )


def _in_view(page: object, scene: str, bodies: list[list[str]], where: str) -> list[str]:
    """What is wrong with the robot's place in the view, at the start and end of its
    animation: the robot's pixels are those that change when its body is hidden."""
    problems = []
    for at in (0.0, 1.0):
        _still(page, scene, at)
        shown = _box_png(page, scene)
        _show_robots(page, scene, bodies, False)
        hidden = _box_png(page, scene)
        _show_robots(page, scene, bodies, True)
        rows, cols = np.nonzero(np.abs(shown - hidden).sum(axis=2) > 30)
        said = f"{where}, animation at {at}"
        if len(rows) <= 200:
            problems.append(f"{said}: the robot is not in view ({len(rows)} px)")
            continue
        height, width = shown.shape[:2]
        if not (rows.min() > 0 and cols.min() > 0):
            problems.append(f"{said}: the robot is cut at the top or left edge")
        if not (rows.max() < height - 1 and cols.max() < width - 1):
            problems.append(f"{said}: the robot is cut at the bottom or right edge")
    return problems


def _plays(page: object, scene: str, where: str) -> list[str]:
    """What is wrong with an animated scene's animation (none: it plays and moves the robot)."""
    # It plays on its own: the animator's clock moves (an event, at any speed).
    start = page.evaluate(f"() => {_viewer(scene)}.animator.time")
    page.wait_for_function(
        f"() => {_viewer(scene)}.animator.playing && {_viewer(scene)}.animator.time !== {start}",
        timeout=120_000,
    )
    # And what it plays moves the robot: a later frame differs from its first (stills, so
    # a slow machine's late first screenshot cannot hide it; a wave is back where it
    # started half way, so look at three points).
    _still(page, scene, 0.0)
    first = _box_png(page, scene)
    changed = []
    for at in (0.25, 0.5, 0.75):
        _still(page, scene, at)
        changed.append(int((np.abs(_box_png(page, scene) - first).sum(axis=2) > 30).sum()))
    if max(changed) > 50:
        return []
    return [f"{where}: the animation does not move (pixels changed at 1/4, 1/2, 3/4: {changed})"]


def _rotates(page: object, scene: str, where: str) -> list[str]:
    """What is wrong with a drag across the scene (none: it turns the camera and the view)."""
    _still(page, scene, 0.0)
    before = _box_png(page, scene)
    camera = page.evaluate(f"() => {_viewer(scene)}.camera.position.toArray()")
    box = page.locator(f"#{scene}").bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    page.mouse.move(x + 80, y + 10, steps=8)
    page.mouse.up()
    page.evaluate(f"() => {_viewer(scene)}.render()")
    moved = page.evaluate(f"() => {_viewer(scene)}.camera.position.toArray()")
    if np.linalg.norm(np.subtract(moved, camera)) <= 1e-3:
        return [f"{where}: a drag did not turn the camera"]
    if (np.abs(_box_png(page, scene) - before).sum(axis=2) > 30).sum() <= 50:
        return [f"{where}: a drag did not change the view"]
    return []


def _controls_cover(page: object, scene: str) -> float:
    """The share of the scene's view that its controls (the GUI panel) cover."""
    return page.evaluate(
        f"""() => {{
            const box = document.getElementById('{scene}').getBoundingClientRect();
            const gui = {_viewer(scene)}.gui.domElement.getBoundingClientRect();
            const w = Math.min(box.right, gui.right) - Math.max(box.left, gui.left);
            const h = Math.min(box.bottom, gui.bottom) - Math.max(box.top, gui.top);
            return Math.max(0, w) * Math.max(0, h) / (box.width * box.height);
        }}"""
    )


@pytest.fixture(scope="module", params=list(SIZES))
def scenes_seen(request: pytest.FixtureRequest, built_book: Path, site: str, browser: object):
    """Every scene of the book seen at one size, each page opened once: what is wrong
    with each (by test), and how many scenes are animated. A page costs seconds of
    software WebGL to open: the tests below read what one visit saw."""
    size = request.param
    problems: dict[str, list[str]] = {"in_view": [], "plays": [], "rotates": [], "controls": []}
    animated = 0
    assert scene_pages(built_book), "no page has a 3D scene"
    for name in scene_pages(built_book):
        commands = bookpages.scene_commands((built_book / name).read_text())
        robots, visuals = robots_in(built_book, name), visuals_in(built_book, name)
        with visit(browser, site + name, viewport=SIZES[size]) as seen:
            page = seen.page
            scenes = zip(scene_ids(page), commands, robots, visuals, strict=True)
            for scene, drawn, names, bodies in scenes:
                where = f"{name} {scene} ({', '.join(names)}) at {size}"
                page.locator(f"#{scene}").scroll_into_view_if_needed()
                wait_for_first_frame(page, scene)
                if any(c["type"] == "set_animation" for c in drawn):
                    animated += 1
                    problems["plays"] += _plays(page, scene, where)
                covered = _controls_cover(page, scene)
                if covered >= 0.1:
                    problems["controls"].append(f"{where}: the controls cover {covered:.0%}")
                box = page.locator(f"#{scene}").bounding_box()
                if not (box["x"] >= 0 and box["x"] + box["width"] <= SIZES[size]["width"] + 1):
                    problems["in_view"].append(f"{where}: the box {box} leaves the page")
                canvas = page.eval_on_selector(
                    f"#{scene} canvas", "c => [c.clientWidth, c.clientHeight]"
                )
                if abs(canvas[0] - box["width"]) > 2 or abs(canvas[1] - box["height"]) > 2:
                    problems["in_view"].append(f"{where}: canvas {canvas}, its box {box}")
                problems["in_view"] += _in_view(page, scene, bodies, where)
                problems["rotates"] += _rotates(page, scene, where)
    return problems, animated


def test_every_scene_shows_its_robot_inside_the_view(scenes_seen) -> None:
    assert not scenes_seen[0]["in_view"], "\n".join(scenes_seen[0]["in_view"])


def test_animated_scenes_play_and_move_the_robot(scenes_seen) -> None:
    assert scenes_seen[1], "no animated scene in the book"
    assert not scenes_seen[0]["plays"], "\n".join(scenes_seen[0]["plays"])


def test_every_scene_rotates_when_dragged(scenes_seen) -> None:
    assert not scenes_seen[0]["rotates"], "\n".join(scenes_seen[0]["rotates"])


def test_scene_controls_leave_the_view_visible(scenes_seen) -> None:
    assert not scenes_seen[0]["controls"], "\n".join(scenes_seen[0]["controls"])


def _scroll_off_screen(page: object, scene: str) -> None:
    off = scroll_off_screen(page, [scene])
    assert off, f"{scene}: the page cannot be scrolled to leave it off the screen"


def test_an_animation_off_the_screen_draws_nothing_and_plays_on_when_back(
    built_book: Path, site: str, browser: object
) -> None:
    """A looping drive drew 60 frames a second off the screen (two cores' worth in software
    WebGL for a page of two): now it is paused there, draws nothing and stays at its time,
    and plays again when scrolled back; a pause by the reader stays a pause."""
    found = [
        (name, k)
        for name in scene_pages(built_book)
        for k, drawn in enumerate(bookpages.scene_commands((built_book / name).read_text()))
        if any(c["type"] == "set_animation" for c in drawn)
    ]
    assert found, "no animated scene in the book"
    name, k = found[0]
    with visit(browser, site + name) as seen:
        page = seen.page
        scene = scene_ids(page)[k]
        viewer, box = _viewer(scene), f"document.getElementById('{scene}')"
        page.locator(f"#{scene}").scroll_into_view_if_needed()
        wait_for_first_frame(page, scene)
        start = page.evaluate(f"() => {viewer}.animator.time")
        page.wait_for_function(
            f"() => {viewer}.animator.playing && {viewer}.animator.time !== {start}",
            timeout=120_000,
        )
        _scroll_off_screen(page, scene)
        page.wait_for_function(
            f"() => {box}.dataset.onScreen === '0' && !{viewer}.animator.playing",
            timeout=120_000,
        )
        frames, at = page.evaluate(f"() => [+{box}.dataset.frames, {viewer}.animator.time]")
        page.wait_for_timeout(1500)  # off the screen nothing is drawn, however long
        assert page.evaluate(f"() => [+{box}.dataset.frames, {viewer}.animator.time]") == [
            frames,
            at,
        ], f"{name} {scene}: off the screen it went on drawing or playing"
        page.locator(f"#{scene}").scroll_into_view_if_needed()
        page.wait_for_function(
            f"() => {viewer}.animator.playing && +{box}.dataset.frames > {frames}"
            f" && {viewer}.animator.time !== {at}",
            timeout=120_000,
        )
        page.evaluate(f"() => {viewer}.animator.pause()")  # the reader's pause
        _scroll_off_screen(page, scene)
        page.wait_for_function(f"() => {box}.dataset.onScreen === '0'", timeout=120_000)
        page.locator(f"#{scene}").scroll_into_view_if_needed()
        page.wait_for_function(f"() => {box}.dataset.onScreen === '1'", timeout=120_000)
        assert not page.evaluate(f"() => {viewer}.animator.playing"), (
            f"{name} {scene}: a paused animation started again when scrolled back"
        )


def test_without_javascript_every_scene_shows_its_still_picture(
    built_book: Path, site: str, browser: object
) -> None:
    for name in scene_pages(built_book):
        with visit(browser, site + name, javascript=False) as seen:
            page = seen.page
            count = page.locator(".rosbook-meshcat-scene").count()
            stills = page.locator(f".rosbook-meshcat-scene img.{STILL_CLASS}")
            assert stills.count() == count > 0, (
                f"{name}: {stills.count()} stills for {count} scenes"
            )
            for k in range(count):
                still = stills.nth(k)
                still.scroll_into_view_if_needed()
                still.wait_for(state="visible")
                assert page.evaluate(
                    "img => img.complete && img.naturalWidth > 0", still.element_handle()
                )
                alt = still.get_attribute("alt")
                assert "3D view of the robot" in alt and ".png" not in alt, alt


def test_in_print_every_scene_is_its_still_picture(
    built_book: Path, site: str, browser: object
) -> None:
    for name in scene_pages(built_book):
        with visit(browser, site + name) as seen:
            page = seen.page
            page.emulate_media(media="print")
            prints = page.locator(f"img.{PRINT_CLASS}")
            assert prints.count() == page.locator(".rosbook-meshcat-scene").count() > 0
            assert page.locator(".rosbook-meshcat-scene").first.is_hidden()
            for k in range(prints.count()):
                picture = prints.nth(k)
                picture.scroll_into_view_if_needed()
                page.wait_for_function(
                    "img => img.complete && img.naturalWidth > 0",
                    arg=picture.element_handle(),
                    timeout=60_000,
                )
