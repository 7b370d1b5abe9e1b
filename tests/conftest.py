"""Every test run is isolated in a ROS domain of its own, even when pytest is run by hand."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from autograder.config import ROOT
from rosbook.isolation import isolated_environ
from rosbook.session import Session, ros


@pytest.fixture(scope="session", autouse=True)
def ros_domain() -> Iterator[int]:
    """A domain of this run's own, set before rclpy is first initialised."""
    with isolated_environ() as domain_id:
        yield domain_id
    ros.shutdown()


@pytest.fixture
def session() -> Iterator[Session]:
    """The notebook session, initialised on wall time; its nodes are destroyed after."""
    ros.init()
    yield ros
    ros.reset()


@pytest.fixture(scope="session")
def built_book(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The whole book built once per test run, every cell executed from a fresh cache.

    Built as `make book` builds it (`--all -W -n --keep-going`, so a warning, a failing
    or a timed-out cell fails it), in a ROS domain of its own. Returns `_build/html`.
    """
    out = tmp_path_factory.mktemp("book")
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "rosbook.isolation",
            "--",
            str(Path(sys.executable).parent / "jupyter-book"),
            "build",
            "--all",
            "-W",
            "-n",
            "--keep-going",
            "--path-output",
            str(out),
            str(ROOT),
        ],
        capture_output=True,
        text=True,
        timeout=1800,
    )
    assert result.returncode == 0, (
        f"the book build failed (exit {result.returncode}):\n"
        + "\n".join((result.stdout + result.stderr).splitlines()[-60:])
    )
    return out / "_build" / "html"
