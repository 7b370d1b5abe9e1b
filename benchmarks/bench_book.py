"""The whole book built from scratch (every cell of every chapter executed), then read.

Built twice in the same run: as ``make book`` builds it (chapters executing side by side,
``rosbook.book.sphinx_execute``) and one chapter at a time, and the ratio of the two.

Opened in headless Chromium over http on loopback, as a static host serves it (text
gzip-compressed): the bytes the first page and the heaviest page transfer (targets:
first page <= 1.2 MB, a page with 3D scenes <= 2 MB), and the time until a 3D scene
has drawn its first frame, next to the time the same page took to load.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

from benchmarks import Figure
from rosbook.book import pages as bookpages
from rosbook.book.chromium import chromium_path, launch
from rosbook.book.site import scene_ids, serve, visit, wait_for_first_frame
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
        html = bookpages.build(out)
        return html, time.monotonic() - start
    finally:
        os.environ.pop(JOBS_VARIABLE, None)
        if saved is not None:
            os.environ[JOBS_VARIABLE] = saved


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
    if first_frames:
        first, load = max(first_frames), max(loads)
        figures += [
            Figure("3D scene: first frame drawn (slowest page)", first, "s"),
            Figure("same pages: load event", load, "s"),
            Figure("first frame / load event", first / load, "x"),
        ]
    return figures
