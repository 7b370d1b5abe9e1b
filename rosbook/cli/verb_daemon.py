"""``ros2 daemon start|stop|status``: the graph daemon (``rosbook.cli.daemon``), worded
as upstream's."""

from __future__ import annotations

import argparse

from rosbook.cli import daemon
from rosbook.cli.reporting import fail


def add_parser(verbs: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    parser = verbs.add_parser("daemon", help="Various daemon related sub-commands")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    commands.add_parser("start", help="Start the daemon if it isn't running").set_defaults(
        func=start
    )
    commands.add_parser("stop", help="Stop the daemon if it is running").set_defaults(func=stop)
    commands.add_parser("status", help="Output the status of the daemon").set_defaults(func=status)


def start(args: argparse.Namespace) -> int:
    if daemon.status() is not None:
        print("The daemon is already running")
        return 0
    if daemon.socket_path() is None:
        return fail("ros2: no private directory for the daemon's socket")
    daemon.spawn()
    if not daemon.wait_until(lambda: daemon.status() is not None):
        return fail(f"ros2: timeout: the daemon did not start within {daemon.WAIT_S:g} s")
    print("The daemon has been started")
    return 0


def stop(args: argparse.Namespace) -> int:
    print("The daemon has been stopped" if daemon.stop() else "The daemon is not running")
    return 0


def status(args: argparse.Namespace) -> int:
    print("The daemon is running" if daemon.status() is not None else "The daemon is not running")
    return 0
