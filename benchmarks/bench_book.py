"""The whole book built from scratch: every cell of every chapter executed."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from benchmarks import Figure
from rosbook import bookpages


def run() -> list[Figure]:
    with tempfile.TemporaryDirectory(prefix="bench-book-") as tmp:
        start = time.monotonic()
        bookpages.build(Path(tmp))
        return [Figure("book full build", time.monotonic() - start, "s")]
