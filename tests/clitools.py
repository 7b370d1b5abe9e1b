"""``ros2`` commands run in the test process, and upstream's fixture nodes
(``tests/fixtures_upstream.py``) as a process of their own: what the tests of the
``ros2`` verbs share."""

from __future__ import annotations

import contextlib
import io
import os
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from rosbook.cli import main
from rosbook.runtime import graph

if TYPE_CHECKING:
    from rclpy.node import Node

FIXTURES = Path(__file__).with_name("fixtures_upstream.py")


class Run(NamedTuple):
    code: int
    out: str
    err: str


def run_ros2(*argv: str) -> Run:
    """``ros2 ARGV`` run in this process: exit code, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(argv))
        except SystemExit as exit:  # argparse
            code = int(exit.code or 0)
    return Run(code, out.getvalue(), err.getvalue())


@contextlib.contextmanager
def fixture_process(*argv: str, up: Callable[[Node], bool]) -> Iterator[None]:
    """``tests/fixtures_upstream.py ARGV`` as a process of its own, until ``up(observer)``
    holds (the limit only guards against a hang); stopped afterwards."""
    process = subprocess.Popen(
        [sys.executable, str(FIXTURES), *argv],
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        assert graph.wait_for(up, timeout=60.0), (
            f"timeout: the fixture nodes {argv} did not come up"
        )
        yield
    finally:
        os.killpg(process.pid, signal.SIGINT)
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
