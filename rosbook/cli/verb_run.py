"""``ros2 run PACKAGE EXECUTABLE [ARG ...]``: start one executable of a built package.

Like the real verb, it looks the package up in the ament index on ``AMENT_PREFIX_PATH``
(here also the venv) and runs ``<prefix>/lib/<package>/<executable>`` with the remaining
arguments, in the same process group (a Ctrl-C in the terminal reaches both), and
returns its exit code.
"""

from __future__ import annotations

import argparse
import signal
import subprocess

from rosbook.cli.reporting import fail
from rosbook.launch.workspace import ExecutableNotFoundError, executable_path


def add_parser(verbs: argparse._SubParsersAction) -> None:
    parser = verbs.add_parser("run", help="Run a package specific executable")
    parser.add_argument("--prefix", help="Prefix command, e.g. 'gdb -ex run --args'")
    parser.add_argument("package_name", help="Name of the ROS package")
    parser.add_argument("executable_name", help="Name of the executable")
    parser.add_argument("argv", nargs=argparse.REMAINDER, help="Pass arbitrary arguments")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        path = executable_path(args.package_name, args.executable_name)
    except ExecutableNotFoundError:
        return fail("No executable found")  # upstream's words, as the others below
    except LookupError:
        return fail(f"Package '{args.package_name}' not found")
    prefix = args.prefix.split() if args.prefix else []
    return run_executable([*prefix, str(path), *args.argv])


def run_executable(cmd: list[str]) -> int:
    """Run ``cmd`` in this process group until it exits and return its exit code.

    As with the real ``ros2 run``, a Ctrl-C in the terminal reaches the executable
    directly (same process group), so here it only means "keep waiting for it to
    finish". A SIGTERM sent to this command is passed on.
    """
    process = subprocess.Popen(cmd)

    def forward(signum: int, frame: object) -> None:
        process.send_signal(signum)

    previous = signal.signal(signal.SIGTERM, forward)
    try:
        while True:
            try:
                return process.wait()
            except KeyboardInterrupt:
                continue
    finally:
        signal.signal(signal.SIGTERM, previous)
