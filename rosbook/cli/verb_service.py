"""``ros2 service list [-t]``, ``ros2 service type SERVICE``, ``ros2 service call``."""

from __future__ import annotations

import argparse
import sys

from rosbook.cli import cli_node
from rosbook.runtime import graph
from rosbook.runtime.interfaces import InterfaceError, from_yaml, message_class
from rosbook.runtime.services import ServiceCallError, call


def add_parser(verbs: argparse._SubParsersAction) -> None:
    parser = verbs.add_parser("service", help="list, inspect and call services")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    listing = commands.add_parser("list", help="the services of the running nodes")
    listing.add_argument("-t", "--show-types", action="store_true", help="show each type")
    listing.add_argument(
        "--include-hidden-services", action="store_true", help="also names with a '_' part"
    )
    listing.set_defaults(func=list_services)
    kind = commands.add_parser("type", help="the type of a service")
    kind.add_argument("service_name")
    kind.set_defaults(func=service_type)
    caller = commands.add_parser("call", help="call a service once and print the response")
    caller.add_argument("service_name")
    caller.add_argument("service_type", help="e.g. std_srvs/srv/SetBool")
    caller.add_argument("values", nargs="?", default="", help="request as YAML: '{data: true}'")
    caller.add_argument("--timeout", type=float, default=5.0, help="seconds to wait (default 5)")
    caller.set_defaults(func=call_service)


def hidden(name: str) -> bool:
    """ROS hides names with a part starting with '_' (an action's own services, say)."""
    return any(part.startswith("_") for part in name.split("/"))


def list_services(args: argparse.Namespace) -> int:
    with cli_node(settle=True) as node:
        services = node.get_service_names_and_types()
    for name, types in sorted(services):
        if hidden(name) and not args.include_hidden_services:
            continue
        print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return 0


def service_type(args: argparse.Namespace) -> int:
    name = "/" + args.service_name.lstrip("/")
    with cli_node() as node:
        graph.lookup(lambda g: name in dict(g.get_service_names_and_types()), node)
        services = dict(node.get_service_names_and_types())
    if name not in services:
        print(f"ros2 service type: no service '{name}' is running", file=sys.stderr)
        return 1
    for type_name in services[name]:
        print(type_name)
    return 0


def call_service(args: argparse.Namespace) -> int:
    try:
        srv_type = message_class(args.service_type)
        request = from_yaml(srv_type.Request, args.values)
    except InterfaceError as exc:
        print(f"ros2 service call: {exc}", file=sys.stderr)
        return 1
    with cli_node() as node:  # waits up to --timeout for a server, as asked
        print(f"requester: making request: {request!r}\n")
        try:
            response = call(node, srv_type, args.service_name, request, timeout=args.timeout)
        except ServiceCallError as exc:
            print(f"ros2 service call: {exc}", file=sys.stderr)
            return 1
    print(f"response:\n{response!r}\n")
    return 0
