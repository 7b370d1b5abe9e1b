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
from tests.test_book_browser import SIZES, robots_in, scene_pages


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


@pytest.mark.parametrize("size", SIZES)
def test_every_scene_shows_its_robot_inside_the_view(
    built_book: Path, site: str, browser: object, size: str
) -> None:
    assert scene_pages(built_book), "no page has a 3D scene"
    for name in scene_pages(built_book):
        robots = robots_in(built_book, name)
        visuals = visuals_in(built_book, name)
        with visit(browser, site + name, viewport=SIZES[size]) as seen:
            page = seen.page
            for scene, names, bodies in zip(scene_ids(page), robots, visuals, strict=True):
                page.locator(f"#{scene}").scroll_into_view_if_needed()
                wait_for_first_frame(page, scene)
                box = page.locator(f"#{scene}").bounding_box()
                assert box["x"] >= 0 and box["x"] + box["width"] <= SIZES[size]["width"] + 1, (
                    name,
                    scene,
                    box,
                )
                canvas = page.eval_on_selector(
                    f"#{scene} canvas", "c => [c.clientWidth, c.clientHeight]"
                )
                assert abs(canvas[0] - box["width"]) <= 2 and abs(canvas[1] - box["height"]) <= 2, (
                    f"{name} {scene}: canvas {canvas} is not the size of its box {box}"
                )
                for at in (0.0, 1.0):
                    _still(page, scene, at)
                    shown = _box_png(page, scene)
                    _show_robots(page, scene, bodies, False)
                    hidden = _box_png(page, scene)
                    _show_robots(page, scene, bodies, True)
                    rows, cols = np.nonzero(np.abs(shown - hidden).sum(axis=2) > 30)
                    where = f"{name} {scene} ({', '.join(names)}) at {size}, animation at {at}"
                    assert len(rows) > 200, f"{where}: the robot is not in view ({len(rows)} px)"
                    height, width = shown.shape[:2]
                    assert rows.min() > 0 and cols.min() > 0, (
                        f"{where}: the robot is cut at the top or left edge"
                    )
                    assert rows.max() < height - 1 and cols.max() < width - 1, (
                        f"{where}: the robot is cut at the bottom or right edge"
                    )


@pytest.mark.parametrize("size", SIZES)
def test_animated_scenes_play_and_every_scene_rotates_when_dragged(
    built_book: Path, site: str, browser: object, size: str
) -> None:
    animated = 0
    for name in scene_pages(built_book):
        commands = bookpages.scene_commands((built_book / name).read_text())
        with visit(browser, site + name, viewport=SIZES[size]) as seen:
            page = seen.page
            for scene, drawn in zip(scene_ids(page), commands, strict=True):
                page.locator(f"#{scene}").scroll_into_view_if_needed()
                wait_for_first_frame(page, scene)
                if any(c["type"] == "set_animation" for c in drawn):
                    animated += 1
                    # It plays on its own: the animator's clock moves (an event, at any speed).
                    start = page.evaluate(f"() => {_viewer(scene)}.animator.time")
                    page.wait_for_function(
                        f"() => {_viewer(scene)}.animator.playing"
                        f" && {_viewer(scene)}.animator.time !== {start}",
                        timeout=120_000,
                    )
                    # And what it plays moves the robot: a later frame differs from its first
                    # (stills, so a slow machine's late first screenshot cannot hide it; a wave
                    # is back where it started half way, so look at three points).
                    _still(page, scene, 0.0)
                    first = _box_png(page, scene)
                    changed = []
                    for at in (0.25, 0.5, 0.75):
                        _still(page, scene, at)
                        changed.append(
                            int((np.abs(_box_png(page, scene) - first).sum(axis=2) > 30).sum())
                        )
                    assert max(changed) > 50, (
                        f"{name} {scene}: the animation does not move (pixels changed at"
                        f" 1/4, 1/2, 3/4 of it: {changed})"
                    )
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
                assert np.linalg.norm(np.subtract(moved, camera)) > 1e-3, (
                    f"{name} {scene}: a drag did not turn the camera"
                )
                assert (np.abs(_box_png(page, scene) - before).sum(axis=2) > 30).sum() > 50, (
                    f"{name} {scene}: a drag did not change the view"
                )
    assert animated, "no animated scene in the book"


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


@pytest.mark.parametrize("size", SIZES)
def test_scene_controls_leave_the_view_visible(
    built_book: Path, site: str, browser: object, size: str
) -> None:
    for name in scene_pages(built_book):
        with visit(browser, site + name, viewport=SIZES[size]) as seen:
            page = seen.page
            for scene in scene_ids(page):
                wait_for_first_frame(page, scene)
                covered = page.evaluate(
                    f"""() => {{
                        const box = document.getElementById('{scene}').getBoundingClientRect();
                        const gui = {_viewer(scene)}.gui.domElement.getBoundingClientRect();
                        const w = Math.min(box.right, gui.right) - Math.max(box.left, gui.left);
                        const h = Math.min(box.bottom, gui.bottom) - Math.max(box.top, gui.top);
                        return Math.max(0, w) * Math.max(0, h) / (box.width * box.height);
                    }}"""
                )
                assert covered < 0.1, (
                    f"{name} {scene} at {size}: the controls cover {covered:.0%} of the view"
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
