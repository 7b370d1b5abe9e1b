"""The built book in a real browser (headless Chromium), served over http with no internet.

Every page at a desktop size: no console error or warning, no failed request, nothing
fetched from another host, light enough. Every 3D scene at desktop and phone sizes:
the robot in view, an animation that plays, a drag that rotates the view, controls that
leave the view visible; a still picture without JavaScript and in print. The maths
rendered from the site's own MathJax and inside its column; tables scroll on a phone.
"""

from __future__ import annotations

import html
import io
import re
from collections.abc import Iterator
from pathlib import Path
from urllib.parse import unquote, urljoin, urlsplit

import numpy as np
import pytest
from PIL import Image

from rosbook.book import pages as bookpages
from rosbook.book.site import DESKTOP, PHONE, scene_ids, serve, visit, wait_for_first_frame
from rosbook.book.stills import PRINT_CLASS, STILL_CLASS

MB = 1_000_000
FIRST_PAGE = "book/intro.html"
SIZES = {"desktop": DESKTOP, "phone": PHONE}


@pytest.fixture(scope="module")
def site(built_book: Path) -> Iterator[str]:
    with serve(built_book) as url:
        yield url


def pages(built_book: Path) -> list[str]:
    """Every page of the book (not the theme's template fragments under _static/)."""
    return sorted(
        str(p.relative_to(built_book))
        for p in built_book.rglob("*.html")
        if p.relative_to(built_book).parts[0] != "_static"
    )


def scene_pages(built_book: Path) -> list[str]:
    return [
        p
        for p in pages(built_book)
        if 'class="rosbook-meshcat-scene"' in (built_book / p).read_text()
    ]


def robots_in(built_book: Path, page: str) -> list[list[str]]:
    """For each scene of ``page``, the names of the robots drawn in it (``/meshcat/<name>``)."""
    return [
        sorted({c["path"].split("/")[2] for c in scene if "/visual_" in c.get("path", "")})
        for scene in bookpages.scene_commands((built_book / page).read_text())
    ]


def test_every_page_loads_with_no_console_error_failed_or_outside_request(
    built_book: Path, site: str, browser: object
) -> None:
    problems = []
    for name in pages(built_book):
        with visit(browser, site + name) as seen:
            found = {"console": seen.console, "failed": seen.failed, "outside": seen.outside}
            for what, items in found.items():
                problems += [f"{name}: {what}: {item}" for item in items]
    assert not problems, "\n".join(problems)


_HREF = re.compile(r'<a\s[^>]*href="([^"]+)"')
_ID = re.compile(r'\sid="([^"]+)"')


def test_every_link_and_anchor_resolves(built_book: Path) -> None:
    ids = {p: set(_ID.findall((built_book / p).read_text())) for p in pages(built_book)}
    broken = []
    for name in ids:
        for href in _HREF.findall((built_book / name).read_text()):
            href = html.unescape(href)
            parts = urlsplit(href)
            if parts.scheme or parts.netloc or href.startswith("javascript:"):
                continue
            target = urlsplit(urljoin(name, parts.path)).path if parts.path else name
            path = built_book / unquote(target)
            if path.is_dir():
                path = path / "index.html"
            if not path.is_file():
                broken.append(f"{name}: {href} (no file)")
            elif parts.fragment and path.suffix == ".html":
                if unquote(parts.fragment) not in ids[str(path.relative_to(built_book))]:
                    broken.append(f"{name}: {href} (no anchor)")
    assert not broken, "\n".join(broken)


def test_the_first_page_and_every_scene_page_are_light(
    built_book: Path, site: str, browser: object
) -> None:
    with visit(browser, site + FIRST_PAGE) as seen:
        assert seen.total_bytes <= 1.2 * MB, _heaviest(seen.transferred)
    for name in scene_pages(built_book):
        with visit(browser, site + name) as seen:
            assert seen.total_bytes <= 2 * MB, f"{name}: " + _heaviest(seen.transferred)


def _heaviest(transferred: dict[str, int]) -> str:
    top = sorted(transferred.items(), key=lambda kv: -kv[1])[:8]
    return f"{sum(transferred.values()) / MB:.2f} MB: " + ", ".join(
        f"{u.rsplit('/', 1)[-1]} {b / MB:.2f}" for u, b in top
    )


def test_maths_is_typeset_from_the_site_and_fits_its_column(
    built_book: Path, site: str, browser: object
) -> None:
    with_maths = [
        p for p in pages(built_book) if "math notranslate" in (built_book / p).read_text()
    ]
    assert with_maths, "no page has maths: the test would prove nothing"
    for size in SIZES.values():
        for name in with_maths:
            with visit(browser, site + name, viewport=size) as seen:
                page = seen.page
                page.wait_for_function(
                    "() => window.MathJax && MathJax.startup && MathJax.startup.promise",
                    timeout=60_000,
                )
                page.evaluate("() => MathJax.startup.promise")
                assert not seen.outside
                raw = page.eval_on_selector_all(
                    ".math", "els => els.filter(e => !e.querySelector('mjx-container')).length"
                )
                assert raw == 0, f"{name}: {raw} formulas left as TeX"
                wide = page.eval_on_selector_all(
                    "mjx-container[display='true']",
                    "els => els.filter(e => { const p = e.closest('.math') || e.parentElement;"
                    " return e.getBoundingClientRect().width > p.getBoundingClientRect().width + 1"
                    " && getComputedStyle(e).overflowX === 'visible'; }).length",
                )
                assert wide == 0, (
                    f"{name} at {size['width']} px: {wide} equations overflow the column"
                )


def test_tables_scroll_rather_than_hide_columns_on_a_phone(
    built_book: Path, site: str, browser: object
) -> None:
    for name in pages(built_book):
        if "<table" not in (built_book / name).read_text():
            continue
        with visit(browser, site + name, viewport=PHONE) as seen:
            hidden = seen.page.eval_on_selector_all(
                "article table",
                """tables => tables.filter(t => {
                    if (t.getBoundingClientRect().right <= window.innerWidth + 1) return false;
                    for (let e = t.parentElement; e; e = e.parentElement) {
                        const o = getComputedStyle(e).overflowX;
                        const scrolls = o === 'auto' || o === 'scroll';
                        if (scrolls && e.clientWidth < e.scrollWidth) return false;
                    }
                    return true;
                }).map(t => t.innerText.slice(0, 40))""",
            )
            assert not hidden, f"{name}: tables cut off at 390 px: {hidden}"


# --- the 3D scenes -------------------------------------------------------------------


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


# --- figures ---------------------------------------------------------------------------

_IMG = re.compile(r"<img\s[^>]*>")
_ALT = re.compile(r'\salt="([^"]*)"')


def test_every_figure_has_alt_text_saying_what_it_shows(built_book: Path) -> None:
    bad = []
    for name in pages(built_book):
        for tag in _IMG.findall((built_book / name).read_text()):
            alt = _ALT.search(tag)
            text = html.unescape(alt.group(1)) if alt else ""
            if len(text.split()) < 4 or re.search(r"\.(png|svg|jpe?g)\b|[0-9a-f]{32}", text):
                bad.append(f"{name}: {tag[:120]}")
    assert not bad, "figures without a description:\n" + "\n".join(bad)


# The book's plots use matplotlib's default 100 dpi and no text under 10 pt (13.9 px in
# the PNG): shown at 72 % of their size or more, their text is 10 px or more on screen.
MATPLOTLIB_TEXT_PX = 10 * 100 / 72


def test_plot_text_is_at_least_10_px_at_1280_px_wide(
    built_book: Path, site: str, browser: object
) -> None:
    checked, small = 0, []
    for name in pages(built_book):
        if ".png" not in (built_book / name).read_text():
            continue
        with visit(browser, site + name) as seen:
            for src, shown, natural in seen.page.eval_on_selector_all(
                "article .cell_output img[src*='_images/'][src$='.png']",
                "async imgs => { for (const i of imgs) { i.loading = 'eager'; await i.decode(); }"
                " return imgs.map(i => [i.getAttribute('src'), i.clientWidth, i.naturalWidth]); }",
            ):
                checked += 1
                if shown / natural * MATPLOTLIB_TEXT_PX < 10:
                    small.append(f"{name} {src}: shown at {shown} of {natural} px")
    assert checked, "no plot found: the test would prove nothing"
    assert not small, "plots shrunk so their text is under 10 px:\n" + "\n".join(small)
