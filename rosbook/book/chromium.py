"""Headless Chromium, driven by Playwright: the browser the book is drawn and tested in.

Playwright never downloads a browser here (``playwright install`` reaches a host these
machines cannot); it drives the system's ``chromium`` (Debian's package). The book build
renders each 3D scene's still picture with it; the tests open the built pages with it.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

# Flags for a headless browser on a machine with no network but loopback: no background
# connections (they are refused many at a time), WebGL through SwiftShader.
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--use-gl=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-quic",
    "--no-first-run",
]


def chromium_path() -> str | None:
    """The system's Chromium, or None where there is none."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


@contextmanager
def launch(path: str) -> Iterator[Any]:
    """A headless Chromium at ``path`` (a Playwright ``Browser``), closed afterwards."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=path, args=CHROMIUM_ARGS)
        try:
            yield browser
        finally:
            browser.close()
