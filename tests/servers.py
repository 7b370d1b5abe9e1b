"""Servers the tests start: Jupyter servers, and the course server's hubs.

Jupyter servers start on a port of the system's choosing (``--port=0``).

A port found free and then handed to a server can be taken by another process before the
server binds it (the server then fails to start, ``port_retries=0``, or moves to another
port the test does not know). A server given port 0 binds one the system picks and writes
its runtime file (``jpserver-PID.json``) with it, in the ``JUPYTER_RUNTIME_DIR`` the test
gave it.
"""

from __future__ import annotations

import glob
import json
import os
import shutil
import subprocess
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from autograder.sandbox import staging_base
from coursehub.hub import serve, stop


def server_url(runtime: Path, server: subprocess.Popen, timeout: float) -> str:
    """The loopback URL of the one Jupyter server that writes its runtime file in
    ``runtime``, once it has; ``RuntimeError`` if it exits first, ``TimeoutError``
    (a hang guard) if it never writes it."""
    deadline = time.monotonic() + timeout
    while True:
        for info in runtime.glob("jpserver-*.json"):
            try:
                return f"http://127.0.0.1:{json.loads(info.read_text())['port']}"
            except (ValueError, KeyError):
                pass  # being written
        if server.poll() is not None:
            raise RuntimeError(f"the server exited ({server.returncode}) before serving")
        if time.monotonic() > deadline:
            raise TimeoutError(f"timeout: no server wrote its runtime file in {runtime}")
        time.sleep(0.2)  # polling for the file, not a wait for time


@contextmanager
def own_tmpdir() -> Iterator[Path]:
    """A temporary folder for one hub alone (its ``TMPDIR``), made where the hub makes its
    sandboxes' private folders (``staging_base``), so the sandbox's user can enter it.
    The tests' hubs run at once under pytest-xdist with students of the same names, and
    each checks that its own students' folders are gone, not the others'."""
    folder = Path(tempfile.mkdtemp(prefix="hub-tmp-", dir=staging_base()))
    folder.chmod(0o755)
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@contextmanager
def running_hub(
    env: dict[str, str], state: Path, stop_s: float
) -> Iterator[tuple[subprocess.Popen[bytes], str, Path]]:
    """``make hub`` (``coursehub.hub.serve``) with ``env`` and a temporary folder of its
    own (``own_tmpdir``), logging to ``state/hub.log``; yields the server, its URL and that
    folder. A hub that never serves fails the test with its log; the hub is stopped after
    (``stop_s``: a hang guard)."""
    with own_tmpdir() as tmp:
        log = (state / "hub.log").open("w")
        try:
            server, url = serve({**env, "TMPDIR": str(tmp)}, log)
        except (RuntimeError, TimeoutError) as exc:
            log.close()
            pytest.fail(f"{exc}:\n" + Path(log.name).read_text())
        try:
            yield server, url, tmp
        finally:
            stop(server, stop_s)
            log.close()


def leftovers(tmp: Path, name: str) -> list[str]:
    """What is left of ``name``'s sandboxes' private folders in a hub's ``tmp``."""
    return glob.glob(os.path.join(tmp, f"rosbook-hub-{name}-*"))


def still_running(processes: dict[int, str]) -> list[str]:
    """Which of ``processes`` (``process_tree``'s pid: start time) still run, as "pid
    command line"; a pid reused by a newer process, or a zombie, is not one of them."""
    alive = []
    for pid, start in processes.items():
        try:
            stat = Path(f"/proc/{pid}/stat").read_text()
            cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        if fields[19] == start and fields[0] != "Z":  # a zombie runs nothing: it is dead
            alive.append(f"{pid} {cmdline.decode(errors='replace')[:160]}")
    return alive
