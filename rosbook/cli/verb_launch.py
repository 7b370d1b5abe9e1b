"""``ros2 launch PACKAGE FILE`` or ``ros2 launch PATH``: run a launch description.

The file is a Python launch file whose ``generate_launch_description()`` returns a
``rosbook.launch.LaunchDescription`` (the real ones import ``launch`` and
``launch_ros``, which are not installable here). ``PACKAGE FILE`` finds ``FILE`` under
the package's ``share/<package>/`` folder, where ``setup.py``'s ``data_files`` install
launch files. Every node runs as its own process; Ctrl-C stops them all.
"""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

from rosbook.launch import workspace
from rosbook.launch.launcher import Launch, LaunchError, load_launch_file


def add_parser(verbs: argparse._SubParsersAction) -> None:
    parser = verbs.add_parser("launch", help="Run a launch file")
    parser.add_argument("package_name", help="Name of the ROS package, or a launch file path")
    parser.add_argument("launch_file_name", nargs="?", help="Name of the launch file")
    parser.set_defaults(func=main)


def find_launch_file(package: str, name: str) -> Path:
    """``share/<package>/**/<name>`` in the package's install prefix."""
    share = workspace.package_prefix(package) / "share" / package
    found = sorted(p for p in share.rglob(name) if p.is_file())
    if not found:
        raise LaunchError(
            f"file '{name}' was not found in the share directory of package '{package}' "
            f"({share}): is it listed in setup.py's data_files, and was the package rebuilt?"
        )
    if len(found) > 1:
        raise LaunchError(f"file '{name}' was found more than once in {share}: {found}")
    return found[0]


def main(args: argparse.Namespace) -> int:
    try:
        if args.launch_file_name is None:
            path = Path(args.package_name)
            if not path.is_file():
                raise LaunchError(f"no launch file '{path}'")
        else:
            path = find_launch_file(args.package_name, args.launch_file_name)
        description = load_launch_file(path)
        system = Launch(description, echo=lambda line: print(line, flush=True))
    except (LaunchError, LookupError) as error:
        print(f"[ERROR] [launch]: {error}", file=sys.stderr)
        return 1
    signal.signal(signal.SIGTERM, _interrupt)  # `kill` stops the nodes too, like Ctrl-C
    return system.start().spin()


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt
