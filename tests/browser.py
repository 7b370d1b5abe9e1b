"""A real browser for the tests: Debian's Chromium driven by Playwright.

Playwright never downloads a browser here (``playwright install`` reaches a host these
machines cannot); it drives the system's ``chromium`` (see ``rosbook.book.chromium``). `.ci/run`
installs it when it is missing. Where no Chromium exists the browser tests are skipped
with a loud reason.
"""

from __future__ import annotations

import os
import re
import subprocess
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from functools import cache
from pathlib import Path
from typing import Any

import pytest

from rosbook.book import pages as bookpages
from rosbook.book.chromium import chromium_path, launch
from rosbook.book.pages import ROOT
from rosbook.book.site import DESKTOP, PHONE
from rosbook.runtime.isolation import RUN_MARKER


@contextmanager
def chromium() -> Iterator[Any]:
    """A headless Chromium (a Playwright ``Browser``), closed afterwards.

    Skips the calling test, loudly, where the machine has no Chromium."""
    path = chromium_path()
    if path is None:
        pytest.skip(
            "NO BROWSER: install Debian's chromium (apt-get install chromium) to run this test"
        )
    with ExitStack() as stack:
        # The browser belongs to no ROS run: started without the run's marker, it is not
        # counted among the processes a grading run or a test must leave behind.
        marker = os.environ.pop(RUN_MARKER, None)
        try:
            browser = stack.enter_context(launch(path))
        finally:
            if marker is not None:
                os.environ[RUN_MARKER] = marker
        yield browser


#: axe-core's rule sets run on every page: WCAG 2.0-2.2 A and AA, best practices, and the
#: experimental rules (label-content-name-mismatch is one).
AXE_TAGS = ["wcag2a", "wcag2aa", "wcag21a", "wcag21aa", "wcag22aa", "best-practice", "experimental"]
#: The impacts a page may not have any violation of.
AXE_IMPACTS = ("serious", "critical")


@cache
def axe_script() -> str:
    """axe-core's script, installed by ``make axe`` (from npm into ``.axe/``, at the
    version the Makefile pins); the calling test fails, saying why, if it cannot be."""
    found = re.search(r"^AXE := (.+)$", (ROOT / "Makefile").read_text(), re.M)
    assert found is not None, "the Makefile names axe-core's script (AXE := ...)"
    made = subprocess.run(
        ["make", "--no-print-directory", "-C", str(ROOT), "axe"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    script = ROOT / found.group(1).strip()
    if made.returncode != 0 or not script.is_file():
        pytest.fail(
            f"make axe could not install axe-core (it needs npm):\n{made.stdout}{made.stderr}"
        )
    return Path(script).read_text()


def axe_violations(page: Any) -> list[str]:
    """axe-core's serious and critical violations on an open page, its frames included
    (an embedded page, such as a feedback page shown in the book): one line per rule,
    with how many elements break it and the first of them."""
    for frame in page.frames:
        frame.add_script_tag(content=axe_script())
    found = page.evaluate(
        "tags => axe.run(document, {resultTypes: ['violations'],"
        " runOnly: {type: 'tag', values: tags}})",
        AXE_TAGS,
    )
    return [
        f"{rule['id']} ({rule['impact']}, {len(rule['nodes'])} elements, e.g."
        f" {rule['nodes'][0]['target']}): {rule['help']}"
        for rule in found["violations"]
        if rule["impact"] in AXE_IMPACTS
    ]


#: The viewports the book is read in.
SIZES = {"desktop": DESKTOP, "phone": PHONE}


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
