"""``ros2 launch PACKAGE FILE [name:=value ...]`` or ``ros2 launch PATH [name:=value ...]``.

The file is a Python launch file whose ``generate_launch_description()`` returns a
``LaunchDescription``, written as for a full install (``from launch import ...``,
``from launch_ros.actions import Node``: here they are ``rosbook.launch``'s), or an XML
or YAML launch file (``*.launch.xml``, ``*.launch.yaml``). ``PACKAGE
FILE`` finds ``FILE`` under the package's ``share/<package>/`` folder, where
``setup.py``'s ``data_files`` install launch files. ``name:=value`` sets a launch
argument; ``-s`` / ``--show-args`` lists the file's arguments as upstream prints them,
``-p`` / ``--print`` its description.
Every process runs on its own; Ctrl-C stops them all.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from pathlib import Path

from rosbook.launch import workspace
from rosbook.launch.launcher import (
    Launch,
    LaunchError,
    format_launch_arguments,
    format_launch_description,
    include,
    load_launch_file,
)


def add_parser(verbs: argparse._SubParsersAction) -> None:
    parser = verbs.add_parser("launch", help="Run a launch file")
    parser.add_argument(
        "-n",
        "--noninteractive",
        default=not sys.stdin.isatty(),
        action="store_true",
        help="Run the launch system non-interactively, with no terminal associated",
    )
    parser.add_argument(
        "-d",
        "--debug",
        default=False,
        action="store_true",
        help="Put the launch system in debug mode, provides more verbose output.",
    )
    command_group = parser.add_mutually_exclusive_group()
    command_group.add_argument(
        "-p",
        "--print",
        "--print-description",
        default=False,
        action="store_true",
        help="Print the launch description to the console without launching it.",
    )
    command_group.add_argument(
        "-s",
        "--show-args",
        "--show-arguments",
        default=False,
        action="store_true",
        help="Show arguments that may be given to the launch file.",
    )
    parser.add_argument(
        "-a",
        "--show-all-subprocesses-output",
        default=False,
        action="store_true",
        help="Show all launched subprocesses' output by overriding their output configuration "
        "using the OVERRIDE_LAUNCH_PROCESS_OUTPUT envvar.",
    )
    parser.add_argument(
        "--launch-prefix",
        help="Prefix command, which should go before all executables. Command must be wrapped "
        "in quotes if it contains spaces (e.g. --launch-prefix 'xterm -e gdb -ex run --args').",
    )
    parser.add_argument(
        "--launch-prefix-filter",
        help="Regex pattern for filtering which executables the --launch-prefix is applied to "
        "by matching the executable name.",
    )
    parser.add_argument(
        "package_name", help="Name of the ROS package which contains the launch file"
    )
    parser.add_argument("launch_file_name", nargs="?", help="Name of the launch file")
    parser.add_argument(
        "launch_arguments",
        nargs="*",
        help="Arguments to the launch file; '<name>:=<value>' (for duplicates, last one wins)",
    )
    parser.set_defaults(func=main)


def find_launch_file(package: str, name: str) -> Path:
    """``share/<package>/**/<name>`` in the package's install prefix."""
    share = workspace.package_prefix(package) / "share" / package
    found = sorted(p for p in share.rglob(name) if p.is_file())
    if not found:
        raise LaunchError(
            f"file '{name}' was not found in the share directory of package '{package}' "
            f"which is at '{share}' (is it listed in setup.py's data_files, and was the "
            "package rebuilt?)"
        )
    if len(found) > 1:
        listed = ", ".join(f"'{p}'" for p in found)
        raise LaunchError(
            f"file '{name}' was found more than once in the share directory of package "
            f"'{package}': [{listed}]"
        )
    return found[0]


def parse_launch_arguments(arguments: list[str]) -> list[tuple[str, str]]:
    """``name:=value`` pairs, the last of a name winning (as upstream)."""
    parsed: dict[str, str] = {}
    for argument in arguments:
        count = argument.count(":=")
        if count == 0 or argument.startswith(":=") or (count == 1 and argument.endswith(":=")):
            raise LaunchError(
                f"malformed launch argument '{argument}', expected format '<name>:=<value>'"
            )
        name, value = argument.split(":=", 1)
        parsed[name] = value
    return list(parsed.items())


def main(args: argparse.Namespace) -> int:
    arguments = list(args.launch_arguments)
    try:
        if Path(args.package_name).is_file():  # single file mode, as upstream decides it
            path = Path(args.package_name)
            if args.launch_file_name is not None:
                arguments.insert(0, args.launch_file_name)
        elif args.launch_file_name is None:
            raise LaunchError(f"no launch file '{args.package_name}'")
        else:
            try:
                path = find_launch_file(args.package_name, args.launch_file_name)
            except workspace.PackageNotFoundError:  # upstream's words, quoting ament's
                package = args.package_name
                message = workspace.not_in_index(package)
                print(f"Package '{package}' not found: \"{message}\"", file=sys.stderr)
                return 1
        if args.launch_prefix is None and args.launch_prefix_filter is not None:
            print(
                "--launch-prefix must be specified if --launch-prefix-filter is provided",
                file=sys.stderr,
            )
            return 1
        # as upstream: given last, these win over launch arguments of the same names
        if args.launch_prefix:
            arguments.append(f"launch-prefix:={args.launch_prefix}")
        if args.launch_prefix_filter:
            arguments.append(f"launch-prefix-filter:={args.launch_prefix_filter}")
        if args.show_all_subprocesses_output:
            os.environ["OVERRIDE_LAUNCH_PROCESS_OUTPUT"] = "both"
        if args.print:
            print(format_launch_description(load_launch_file(path)))
            return 0
        if args.show_args:
            print(format_launch_arguments(load_launch_file(path)))
            return 0
        description = include(path, parse_launch_arguments(arguments))
        system = Launch(description, echo=lambda line: print(line, flush=True))
    except (LaunchError, LookupError) as error:
        print(f"[ERROR] [launch]: {error}", file=sys.stderr)
        return 1
    except Exception as error:  # the launch file's own error, worded as upstream reports it
        print(
            f"[ERROR] [launch]: Caught exception in launch (see debug for traceback): {error}",
            file=sys.stderr,
        )
        return 1
    signal.signal(signal.SIGTERM, _interrupt)  # `kill` stops the nodes too, like Ctrl-C
    # A shell starts a background job (`cmd &` in a script, under `nohup`) with SIGINT
    # ignored, which Python then leaves ignored: Ctrl-C would be lost. Like upstream
    # launch, which installs its own SIGINT handler, take it whatever was inherited.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    return system.start().spin()


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt
