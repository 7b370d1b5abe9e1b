"""Run a command with the CPU oversubscribed (``python -m rosbook.runtime.stress``).

``make stress`` runs the book build and the test suite this way, so that a verdict that
depends on machine speed shows up on a developer's machine, not on a student's old laptop
or a shared CI runner. The busy processes (``--per-core`` per CPU core, default two) are
stopped whatever happens: when the command ends or fails, on Ctrl-C or SIGTERM, and, as
each is tied to this process with ``PR_SET_PDEATHSIG``, even when this process is killed.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

#: A busy process: asks the kernel to kill it when its parent dies, then spins.
BUSY = (
    "import ctypes, signal, os, sys\n"
    "ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG\n"
    "os.getppid() == int(sys.argv[1]) or sys.exit()  # the parent already died\n"
    "while True:\n    pass\n"
)


def cores() -> int:
    """CPU cores this process may run on."""
    return len(os.sched_getaffinity(0))


@contextmanager
def busy_processes(count: int) -> Iterator[list[subprocess.Popen[bytes]]]:
    """``count`` processes that each keep one core busy, all killed on leaving."""
    procs: list[subprocess.Popen[bytes]] = []
    try:
        for _ in range(count):
            procs.append(
                subprocess.Popen(
                    [sys.executable, "-c", BUSY, str(os.getpid())],
                    stdin=subprocess.DEVNULL,
                    start_new_session=True,  # a terminal's Ctrl-C reaches us, not them
                )
            )
        yield procs
    finally:
        for proc in procs:
            proc.kill()
        for proc in procs:
            proc.wait()


def _raise_interrupt(signum: int, _frame: FrameType | None) -> None:
    raise KeyboardInterrupt(signal.Signals(signum).name)


def run(command: list[str], per_core: float = 2.0) -> int:
    """Run ``command`` next to ``per_core`` busy processes per core; its exit code."""
    count = max(1, round(per_core * cores()))
    signal.signal(signal.SIGTERM, _raise_interrupt)
    start = time.monotonic()
    print(f"stress: {count} busy processes on {cores()} core(s) while running: {' '.join(command)}")
    sys.stdout.flush()
    with busy_processes(count):
        proc = subprocess.Popen(command)
        try:
            code = proc.wait()
        except KeyboardInterrupt:
            proc.send_signal(signal.SIGINT)
            code = proc.wait()
    print(
        f"stress: exit code {code} after {time.monotonic() - start:.0f} s; busy processes stopped"
    )
    return code


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rosbook.runtime.stress", description=__doc__)
    parser.add_argument(
        "--per-core", type=float, default=2.0, help="busy processes per CPU core (default 2)"
    )
    parser.add_argument("command", nargs=argparse.REMAINDER, help="-- COMMAND [ARGS...]")
    args = parser.parse_args(argv)
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        parser.error("no command given: python -m rosbook.runtime.stress -- COMMAND")
    return run(command, args.per_core)


if __name__ == "__main__":
    sys.exit(main())
