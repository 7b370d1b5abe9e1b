"""Jupyter servers the tests start on a port of the system's choosing (``--port=0``).

A port found free and then handed to a server can be taken by another process before the
server binds it (the server then fails to start, ``port_retries=0``, or moves to another
port the test does not know). A server given port 0 binds one the system picks and writes
its runtime file (``jpserver-PID.json``) with it, in the ``JUPYTER_RUNTIME_DIR`` the test
gave it.
"""

from __future__ import annotations

import json
import subprocess
import time
from pathlib import Path


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
