"""``ros2 interface show TYPE`` and ``ros2 interface package PACKAGE``, worded as upstream's."""

from __future__ import annotations

import argparse

from rosbook.cli.reporting import fail, reports_errors
from rosbook.runtime import interfaces


def add_parser(verbs: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    parser = verbs.add_parser("interface", help="Message, service and action definitions")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = commands.add_parser("show", help="Print an interface's definition, nested types expanded")
    p.add_argument("type", help="e.g. geometry_msgs/msg/Pose")
    p.set_defaults(func=show)

    p = commands.add_parser("package", help="Print the interfaces of a package")
    p.add_argument("package_name")
    p.set_defaults(func=package)


@reports_errors
def show(args: argparse.Namespace) -> int:
    package, kind, name = interfaces.split_type(args.type)  # or a one-line error
    prefix = interfaces.package_prefix(package)
    if prefix is None:
        return fail(f"Unknown package '{package}'")
    try:
        print(interfaces.show(args.type))
    except interfaces.InterfaceError:
        idl = prefix / "share" / package / kind / f"{name}.idl"
        return fail(f"Could not find the interface '{idl}'")
    return 0


@reports_errors
def package(args: argparse.Namespace) -> int:
    if interfaces.package_prefix(args.package_name) is None:
        return fail(f"Unknown package '{args.package_name}'")
    print(*interfaces.interfaces(args.package_name), sep="\n")
    return 0
