"""A real browser for the tests: Debian's Chromium driven by Playwright.

Playwright never downloads a browser here (``playwright install`` reaches a host these
machines cannot); it drives the system's ``chromium`` (see ``rosbook.book.chromium``). `.ci/run`
installs it when it is missing. Where no Chromium exists the browser tests are skipped
with a loud reason.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

from rosbook.book.chromium import chromium_path, launch


@contextmanager
def chromium() -> Iterator[Any]:
    """A headless Chromium (a Playwright ``Browser``), closed afterwards.

    Skips the calling test, loudly, where the machine has no Chromium."""
    path = chromium_path()
    if path is None:
        pytest.skip(
            "NO BROWSER: install Debian's chromium (apt-get install chromium) to run this test"
        )
    with launch(path) as browser:
        yield browser
