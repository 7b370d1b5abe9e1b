"""`make stress`: the command runs beside busy processes, which never outlive the run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from rosbook.runtime.stress import cores

#: The command under stress: lists the busy processes of its parent (the stress runner),
#: prints their PIDs and its own, then exits with code 3 or waits to be killed.
LIST_BUSY = """
import os, sys, time
from pathlib import Path
runner = str(os.getppid())
busy = []
for proc in Path('/proc').iterdir():
    try:
        argv = (proc / 'cmdline').read_bytes().split(b'\\0')
    except OSError:
        continue
    if any(b'PR_SET_PDEATHSIG' in a for a in argv) and runner.encode() in argv:
        busy.append(proc.name)
print('busy', *busy, flush=True)
print('me', os.getpid(), flush=True)
if sys.argv[1] == 'wait':
    time.sleep(120)
sys.exit(3)
"""


def alive(pids: list[int]) -> list[int]:
    """Those of ``pids`` that still run (zombies count as gone)."""
    running = []
    for pid in pids:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            running.append(pid)
    return running


def stress(mode: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "rosbook.runtime.stress", "--per-core", "1", "--"]
        + [sys.executable, "-c", LIST_BUSY, mode],
        stdout=subprocess.PIPE,
        text=True,
    )


def read_pids(runner: subprocess.Popen[str]) -> tuple[list[int], int]:
    assert runner.stdout is not None
    lines = {}
    for line in runner.stdout:
        key, *values = line.split()
        lines[key] = [int(v) for v in values if v.isdigit()]
        if key == "me":
            break
    return lines["busy"], lines["me"][0]


def wait_gone(pids: list[int], limit: float = 60.0) -> list[int]:
    deadline = time.monotonic() + limit  # a guard against a hang, not a verdict on speed
    while alive(pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    return alive(pids)


def test_stress_runs_the_command_beside_busy_processes_and_stops_them() -> None:
    runner = stress("exit")
    busy, _ = read_pids(runner)
    runner.communicate(timeout=120)
    assert len(busy) == cores(), f"expected one busy process per core, found {busy}"
    assert runner.returncode == 3, "the command's exit code is the run's"
    assert alive(busy) == [], "busy processes outlived the stress run"


def test_busy_processes_die_with_a_killed_stress_runner() -> None:
    runner = stress("wait")
    busy, command = read_pids(runner)
    try:
        assert busy, "no busy processes were started"
        runner.kill()  # no clean-up code runs: the kernel must stop them
        runner.wait()
        assert wait_gone(busy) == [], "busy processes outlived a killed stress runner"
    finally:
        os.kill(command, signal.SIGKILL)


def test_busy_processes_stop_on_sigterm() -> None:
    runner = stress("wait")
    busy, command = read_pids(runner)
    try:
        runner.send_signal(signal.SIGTERM)
        runner.communicate(timeout=120)
        assert wait_gone(busy) == [], "busy processes outlived a terminated stress run"
    finally:
        if alive([command]):
            os.kill(command, signal.SIGKILL)
