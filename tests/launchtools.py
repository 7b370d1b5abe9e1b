"""``ros2 launch`` as a process in a terminal of its own, and reading what it prints: what
the launch tests share."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from pathlib import Path


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"


#: Runs ``python -m rosbook.cli ARGV`` with SIGINT ignored, as a shell starts a
#: background job (``cmd &`` in a script, ``nohup``): the disposition is inherited.
SIGINT_IGNORED = (
    "import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_IGN); "
    "os.execv(sys.executable, [sys.executable, '-m', 'rosbook.cli', *sys.argv[1:]])"
)


def start_launch(
    env: dict[str, str], *argv: str, sigint_ignored: bool = False
) -> subprocess.Popen[str]:
    """``ros2 launch ARGV`` in a terminal of its own (a Ctrl-C goes to its group)."""
    prefix = ["-c", SIGINT_IGNORED] if sigint_ignored else ["-m", "rosbook.cli"]
    return subprocess.Popen(
        [sys.executable, *prefix, "launch", *argv],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )


def read_until(
    proc: subprocess.Popen[str], marker: str | None, lines: list[str], guard: float = 30.0
) -> list[str]:
    """Append ``proc``'s output lines to ``lines`` up to the first holding ``marker``, or
    to its end if ``marker`` is None (the launcher is SIGKILLed if that takes ``guard``
    s). Always the same reader: ``communicate`` after it would lose what it read ahead."""
    assert proc.stdout is not None
    watchdog = threading.Timer(guard, os.killpg, (proc.pid, signal.SIGKILL))
    watchdog.start()
    for line in proc.stdout:
        lines.append(line)
        if marker is not None and marker in line:
            break
    watchdog.cancel()
    return lines
