"""``ros2 service list [-t]``, ``ros2 service type SERVICE``, ``ros2 service call``."""

from __future__ import annotations

import argparse
import sys

from rclpy.node import Node

from rosbook.cli import cli_node
from rosbook.cli.reporting import fail
from rosbook.runtime import graph
from rosbook.runtime.interfaces import InterfaceError, from_yaml, message_class
from rosbook.runtime.services import ServiceCallError, call


def add_parser(verbs: argparse._SubParsersAction) -> None:
    parser = verbs.add_parser("service", help="list, inspect and call services")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    listing = commands.add_parser("list", help="the services of the running nodes")
    listing.add_argument("-t", "--show-types", action="store_true", help="show each type")
    listing.add_argument("-c", "--count-services", action="store_true", help="only the count")
    hidden_option = {"action": "store_true", "help": "also names with a '_' part"}
    listing.add_argument("--include-hidden-services", **hidden_option)
    listing.set_defaults(func=list_services)
    kind = commands.add_parser("type", help="the type of a service")
    kind.add_argument("service_name")
    kind.add_argument("--include-hidden-services", **hidden_option)
    kind.set_defaults(func=service_type)
    caller = commands.add_parser("call", help="call a service once and print the response")
    caller.add_argument("service_name")
    caller.add_argument("service_type", help="e.g. std_srvs/srv/SetBool")
    caller.add_argument("values", nargs="?", default="", help="request as YAML: '{data: true}'")
    caller.add_argument("--timeout", type=float, default=5.0, help="seconds to wait (default 5)")
    caller.set_defaults(func=call_service)


def services(node: Node, *, include_hidden: bool) -> dict[str, list[str]]:
    """The services on the graph with their types, by name: hidden ones (a part of the
    name starts with '_', an action's own services say) only if asked, never the CLI's
    own node's."""
    own = node.get_fully_qualified_name() + "/"
    return {
        name: list(types)
        for name, types in sorted(node.get_service_names_and_types())
        if not name.startswith(own) and (include_hidden or not graph.is_hidden(name))
    }


def list_services(args: argparse.Namespace) -> int:
    with cli_node(settle=True) as node:
        found = services(node, include_hidden=args.include_hidden_services)
    if args.count_services:
        print(len(found))
        return 0
    for name, types in found.items():
        print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return 0


def service_type(args: argparse.Namespace) -> int:
    """The service's type(s); as upstream, nothing at all and exit 1 when it is absent."""
    name = "/" + args.service_name.lstrip("/")
    hidden = args.include_hidden_services
    with cli_node() as node:
        graph.lookup(lambda g: name in services(g, include_hidden=hidden), node)
        found = services(node, include_hidden=hidden)
    if name not in found:
        return 1
    print(*found[name], sep="\n")
    return 0


def call_service(args: argparse.Namespace) -> int:
    try:
        srv_type = message_class(args.service_type)
    except InterfaceError:
        return fail("The passed service type is invalid")
    try:
        request = from_yaml(srv_type.Request, args.values)
    except InterfaceError as exc:
        return fail(f"Failed to populate field: {exc}")
    with cli_node() as node:  # waits up to --timeout for a server, as asked
        print("waiting for service to become available...")
        print(f"requester: making request: {request!r}\n")
        try:
            response = call(node, srv_type, args.service_name, request, timeout=args.timeout)
        except ServiceCallError as exc:
            print(f"ros2 service call: {exc}", file=sys.stderr)
            return 1
    print(f"response:\n{response!r}\n")
    return 0
