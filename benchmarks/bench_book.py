"""The whole book built from scratch: every cell of every chapter executed."""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

from autograder.config import ROOT
from benchmarks import Figure


def build_seconds(toc: Path | None = None) -> float:
    """Wall time of a fresh, isolated `jupyter-book build --all -W -n --keep-going`."""
    jupyter_book = str(Path(sys.executable).parent / "jupyter-book")
    with tempfile.TemporaryDirectory(prefix="bench-book-") as out:
        argv = [
            sys.executable,
            "-m",
            "rosbook.isolation",
            "--",
            jupyter_book,
            "build",
            "--all",
            "-W",
            "-n",
            "--keep-going",
            "--path-output",
            out,
        ]
        if toc is not None:
            argv += ["--toc", str(toc)]
        start = time.monotonic()
        subprocess.run([*argv, str(ROOT)], check=True, capture_output=True)
        return time.monotonic() - start


def run() -> list[Figure]:
    return [Figure("book full build", build_seconds(), "s")]
