"""A real browser for the tests: Debian's Chromium driven by Playwright.

Playwright never downloads a browser here (``playwright install`` reaches a host these
machines cannot); it drives the system's ``chromium`` (see ``rosbook.book.chromium``). `.ci/run`
installs it when it is missing. Where no Chromium exists the browser tests are skipped
with a loud reason.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from typing import Any

import pytest

from rosbook.book.chromium import chromium_path, launch
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
