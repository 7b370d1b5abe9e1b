"""The whole book built from scratch (every cell of every chapter executed), then read.

Built twice in the same run: as ``make book`` builds it (chapters executing side by side,
``rosbook.book.sphinx_execute``) and one chapter at a time, and the ratio of the two.

Opened in headless Chromium over http on loopback, as a static host serves it (text
gzip-compressed): the bytes the first page and the heaviest page transfer (targets:
first page <= 1.2 MB, a page with 3D scenes <= 2 MB), and the time until a 3D scene
has drawn its first frame, next to the time the same page took to load; and the
processor time the browser spends on the page with the most animated scenes, scrolled
so that none is on the screen, against one of them in view (target: off the screen
<= 0.25 of in view: an animation off the screen is paused).
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path
from typing import Any

from autograder.sandbox import process_tree
from benchmarks import Figure, sized
from rosbook.book import pages as bookpages
from rosbook.book.chromium import chromium_path, launch
from rosbook.book.site import (
    scene_ids,
    scroll_off_screen,
    serve,
    visit,
    wait_for_first_frame,
)
from rosbook.book.sphinx_execute import JOBS_VARIABLE

FIRST_PAGE = "book/intro.html"
MB = 1e6


def timed_build(out: Path, jobs: str | None = None) -> tuple[Path, float]:
    """The book built from scratch into ``out`` (``jobs`` chapters executing at once,
    default as ``make book``), and the seconds it took."""
    saved = os.environ.get(JOBS_VARIABLE)
    if jobs is not None:
        os.environ[JOBS_VARIABLE] = jobs
    try:
        start = time.monotonic()
        html = bookpages.build(out, sized(None, QUICK_CHAPTERS))
        return html, time.monotonic() - start
    finally:
        os.environ.pop(JOBS_VARIABLE, None)
        if saved is not None:
            os.environ[JOBS_VARIABLE] = saved


#: What quick mode builds: the book's first chapter, not the whole book.
QUICK_CHAPTERS = ["book/robots_and_ros"]


def run() -> list[Figure]:
    with tempfile.TemporaryDirectory(prefix="bench-book-") as tmp:
        _, serial = timed_build(Path(tmp) / "serial", jobs="1")
        html, seconds = timed_build(Path(tmp) / "book")
        figures = [
            Figure("book full build", seconds, "s"),
            Figure("book full build, one chapter executing at a time", serial, "s"),
            Figure("book full build speed-up, chapters side by side", serial / seconds, "x"),
        ]
        path = chromium_path()
        if path is None:
            print("   NO CHROMIUM: page weights and first-frame times not measured")
            return figures
        with serve(html) as site, launch(path) as browser:
            figures += read(html, site, browser)
    return figures


def read(html: Path, site: str, browser: object) -> list[Figure]:
    """Page weights and the first 3D frame, measured in ``browser`` on the served book."""
    weights: dict[str, tuple[int, int]] = {}
    first_frames: list[float] = []
    loads: list[float] = []
    pages = [p.relative_to(html) for p in html.rglob("*.html")]
    for page in sorted(str(p) for p in pages if p.parts[0] != "_static"):
        with visit(browser, site + page) as seen:
            weights[page] = (seen.total_bytes, seen.decoded_bytes)
            scenes = scene_ids(seen.page)
            if scenes:
                # time from navigation start to the first frame of the page's first scene
                wait_for_first_frame(seen.page, scenes[0])
                first_frames.append(
                    seen.page.evaluate(
                        "id => +document.getElementById(id).dataset.firstFrameMs / 1000",
                        scenes[0],
                    )
                )
                loads.append(
                    seen.page.evaluate(
                        "() => performance.getEntriesByType('navigation')[0].loadEventEnd / 1000"
                    )
                )
    heaviest = max(weights, key=lambda p: weights[p][0])
    figures = [
        Figure("first page transferred (target <= 1.2 MB)", weights[FIRST_PAGE][0] / MB, "MB"),
        Figure("first page uncompressed", weights[FIRST_PAGE][1] / MB, "MB"),
        Figure(f"heaviest page transferred ({heaviest})", weights[heaviest][0] / MB, "MB"),
        Figure(f"heaviest page uncompressed ({heaviest})", weights[heaviest][1] / MB, "MB"),
    ]
    figures += animation_cpu(html, site, browser)
    if first_frames:
        first, load = max(first_frames), max(loads)
        figures += [
            Figure("3D scene: first frame drawn (slowest page)", first, "s"),
            Figure("same pages: load event", load, "s"),
            Figure("first frame / load event", first / load, "x"),
        ]
    return figures


#: Seconds over which the browser's processor time is measured, each way.
CPU_WINDOW_S = 5.0


def browser_cpu_seconds() -> float:
    """Processor seconds used so far by the Chromium processes this process started."""
    tick, total = os.sysconf("SC_CLK_TCK"), 0.0
    for pid in process_tree(os.getpid()):
        try:
            stat = Path(f"/proc/{pid}/stat").read_text()
        except OSError:  # ended meanwhile
            continue
        fields = stat.rsplit(")", 1)[1].split()
        if "chrom" in stat[stat.index("(") + 1 : stat.rindex(")")]:
            total += (int(fields[11]) + int(fields[12])) / tick
    return total


def _cores_used(page: Any) -> float:
    start, before = time.monotonic(), browser_cpu_seconds()
    page.wait_for_timeout(CPU_WINDOW_S * 1000)
    return (browser_cpu_seconds() - before) / (time.monotonic() - start)


def animation_cpu(html: Path, site: str, browser: object) -> list[Figure]:
    """The browser's processor use (cores) on the page with the most animated scenes: at
    the top of the page when no scene is in view there, at the bottom otherwise, and with
    its first animated scene in view."""
    animated: dict[str, list[int]] = {}
    for path in html.rglob("*.html"):
        scenes = bookpages.scene_commands(path.read_text())
        found = [k for k, s in enumerate(scenes) if any(c["type"] == "set_animation" for c in s)]
        if found:
            animated[str(path.relative_to(html))] = found
    if not animated:
        return []
    page_name = max(animated, key=lambda p: len(animated[p]))
    with visit(browser, site + page_name) as seen:
        page = seen.page
        scenes = scene_ids(page)
        for scene in scenes:
            wait_for_first_frame(page, scene)
        off = scroll_off_screen(page, scenes)
        if not off:
            print(f"   {page_name}: no scroll leaves every scene off the screen")
            return []
        page.wait_for_function(  # every scene has heard that it is off the screen
            "ids => ids.every(id => document.getElementById(id).dataset.onScreen === '0')",
            arg=scenes,
        )
        idle = _cores_used(page)
        first = scenes[animated[page_name][0]]
        page.locator(f"#{first}").scroll_into_view_if_needed()
        page.wait_for_function(
            "id => document.getElementById(id).dataset.onScreen === '1'", arg=first
        )
        shown = _cores_used(page)
    return [
        Figure(f"browser on {page_name}, no scene on the screen", idle, "cores"),
        Figure("same page, one animated scene in view", shown, "cores"),
        Figure("no scene on the screen / one in view (target <= 0.25)", idle / shown, "x"),
    ]
