"""``ros2 service list [-t]``, ``ros2 service type SERVICE``, ``ros2 service call``,
``ros2 service echo SERVICE``, ``ros2 service info SERVICE``, ``ros2 service find TYPE``."""

from __future__ import annotations

import argparse
import math
import sys
import time
from typing import Any

import yaml
from rclpy.node import Node
from rclpy.qos import qos_profile_services_default
from service_msgs.msg import ServiceEventInfo

from rosbook.cli import (
    ADDITION,
    add_message_format_arguments,
    add_strategy_arguments,
    add_values_argument,
    cli_node,
    message_format,
    values,
)
from rosbook.cli.reporting import fail
from rosbook.runtime import graph
from rosbook.runtime.interfaces import InterfaceError, from_yaml, message_class, to_csv, to_plain
from rosbook.runtime.services import ServiceCallError, call


def add_parser(verbs: argparse._SubParsersAction) -> None:
    parser = verbs.add_parser("service", help="list, inspect, call and echo services")
    parser.add_argument(
        "--include-hidden-services",
        dest="verb_include_hidden_services",
        action="store_true",
        help="Consider hidden services as well",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    listing = commands.add_parser("list", help="the services of the running nodes")
    add_strategy_arguments(listing)
    listing.add_argument("-t", "--show-types", action="store_true", help="show each type")
    listing.add_argument("-c", "--count-services", action="store_true", help="only the count")
    hidden_option = {"action": "store_true", "help": "also names with a '_' part"}
    listing.add_argument("--include-hidden-services", **hidden_option)
    listing.set_defaults(func=list_services)
    kind = commands.add_parser("type", help="the type of a service")
    kind.add_argument("service_name")
    kind.add_argument(
        "--include-hidden-services",
        action="store_true",
        help=f"also names with a '_' part {ADDITION} (upstream: ros2 service --include-hidden-"
        "services type)",
    )
    kind.set_defaults(func=service_type)
    caller = commands.add_parser("call", help="call a service once and print the response")
    caller.add_argument("service_name")
    caller.add_argument("service_type", help="e.g. std_srvs/srv/SetBool")
    add_values_argument(caller, "values", "", "request as YAML: '{data: true}'")
    caller.add_argument(
        "-r",
        "--rate",
        metavar="N",
        type=float,
        default=None,
        help="Repeat the call at a specific rate in Hz",
    )
    caller.add_argument(
        "--timeout",
        type=float,
        default=5.0,
        help=f"seconds to wait for each response (default 5) {ADDITION}",
    )
    caller.set_defaults(func=call_service)
    add_introspection_parsers(commands)


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


def hidden_services(args: argparse.Namespace) -> bool:
    """``--include-hidden-services``, given to the verb or to the command."""
    return bool(
        args.verb_include_hidden_services or getattr(args, "include_hidden_services", False)
    )


def list_services(args: argparse.Namespace) -> int:
    with cli_node(settle=True, args=args) as node:
        found = services(node, include_hidden=hidden_services(args))
    if args.count_services:
        print(len(found))
        return 0
    for name, types in found.items():
        print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return 0


def service_type(args: argparse.Namespace) -> int:
    """The service's type(s); as upstream, nothing at all and exit 1 when it is absent."""
    name = "/" + args.service_name.lstrip("/")
    hidden = hidden_services(args)
    with cli_node() as node:
        graph.lookup(lambda g: name in services(g, include_hidden=hidden), node)
        found = services(node, include_hidden=hidden)
    if name not in found:
        return 1
    print(*found[name], sep="\n")
    return 0


def call_service(args: argparse.Namespace) -> int:
    """One call, or with ``-r`` one at each period until interrupted (as upstream)."""
    if args.rate is not None and args.rate <= 0:
        return fail("rate must be greater than zero")
    try:
        srv_type = message_class(args.service_type)
    except InterfaceError:
        return fail("The passed service type is invalid")
    if not hasattr(srv_type, "Request"):
        return fail("The passed type is not a service")
    try:
        request = from_yaml(srv_type.Request, values(args, "values"))
    except InterfaceError as exc:
        return fail(f"Failed to populate field: {exc}")
    with cli_node() as node:  # waits up to --timeout for a server, as asked
        print("waiting for service to become available...")
        while True:
            print(f"requester: making request: {request!r}\n", flush=True)
            last_call = time.monotonic()
            try:
                response = call(node, srv_type, args.service_name, request, timeout=args.timeout)
            except ServiceCallError as exc:
                print(f"ros2 service call: {exc}", file=sys.stderr)
                return 1
            print(f"response:\n{response!r}\n", flush=True)
            if args.rate is None:
                return 0
            # the next call is due one period after this one began (upstream's pacing)
            time.sleep(max(0.0, last_call + 1.0 / args.rate - time.monotonic()))


# -- echo, info, find (as ros2service's) ---------------------------------------------
def add_introspection_parsers(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    echo = commands.add_parser("echo", help="Echo a service (its introspection events)")
    echo.add_argument("service_name", help="Name of the ROS service to echo (e.g. '/add_two_ints')")
    echo.add_argument("service_type", nargs="?", help="Type of the ROS service")
    add_message_format_arguments(echo)
    echo.add_argument(
        "-n", "--max-count", type=int, default=None, help=f"exit after N events {ADDITION}"
    )
    echo.set_defaults(func=service_echo)
    info = commands.add_parser("info", help="Print information about a service")
    add_strategy_arguments(info)
    info.add_argument("service_name", help="Name of the ROS service (e.g. '/add_two_ints')")
    info.add_argument(
        "--include-hidden-services", action="store_true", help="Consider hidden services as well"
    )
    info.set_defaults(func=service_info)
    find = commands.add_parser("find", help="Output a list of available services of a given type")
    find.add_argument("service_type", help="e.g. 'rcl_interfaces/srv/ListParameters'")
    find.add_argument(
        "-c", "--count-services", action="store_true", help="Only display the number found"
    )
    find.add_argument(
        "--include-hidden-services", action="store_true", help="Consider hidden services as well"
    )
    find.set_defaults(func=service_find)


def _event_names() -> dict[int, str]:
    """``ServiceEventInfo``'s event numbers by their constants' names."""
    return {
        getattr(ServiceEventInfo, name): name
        for name in dir(ServiceEventInfo)
        if name.isupper() and isinstance(getattr(ServiceEventInfo, name), int)
    }


def service_echo(args: argparse.Namespace) -> int:
    """Print the events a service (or its clients) publish on ``SERVICE/_service_event``
    when introspection is enabled there (``configure_introspection``), as upstream."""
    name = "/" + args.service_name.lstrip("/")
    events = f"{name}/_service_event"
    count = math.inf if args.max_count is None else args.max_count
    names = _event_names()
    printed = 0

    options = message_format(args)

    def show(event: Any) -> None:
        nonlocal printed
        if args.csv:
            print(to_csv(event, **options), flush=True)
        else:
            plain = to_plain(event, **options)
            plain["info"]["event_type"] = names.get(event.info.event_type, event.info.event_type)
            text = yaml.safe_dump(
                plain, default_flow_style=args.flow_style, sort_keys=False, width=sys.maxsize
            )
            print(text + "---", flush=True)
        printed += 1

    with cli_node() as node:
        if args.service_type is None:
            graph.lookup(lambda g: name in dict(g.get_service_names_and_types()), node)
            types = dict(node.get_service_names_and_types()).get(name)
            if not types:
                print("Could not load the type for the passed service", file=sys.stderr)
                return 1
            type_name = types[0]
        else:
            type_name = args.service_type
        try:
            srv_type = message_class(type_name)
        except InterfaceError:
            print(f"The service type '{type_name}' is invalid", file=sys.stderr)
            return 1
        subscription = node.create_subscription(
            srv_type.Event, events, show, qos_profile_services_default
        )
        if not graph.lookup(lambda _: subscription.get_publisher_count() > 0, node):
            print(
                f"No publishers on topic '{events}'; "
                "is service introspection on the client or server enabled?",
                flush=True,
            )
        graph.wait_for(lambda _: printed >= count, node, timeout=math.inf)
    return 0


def service_info(args: argparse.Namespace) -> int:
    name = args.service_name
    with cli_node() as node:
        if graph.lookup(lambda g: name in dict(g.get_service_names_and_types()), node):
            graph.settle(node)  # every server and client of it
        types = services(node, include_hidden=hidden_services(args)).get(name)
        if types is None:
            print(f"Unknown service '{name}'", file=sys.stderr)
            return 1
        print(f"Type: {types[0] if len(types) == 1 else types}")
        print(f"Clients count: {node.count_clients(name)}")
        print(f"Services count: {node.count_services(name)}")
    return 0


def service_find(args: argparse.Namespace) -> int:
    with cli_node(settle=True) as node:
        found_all = services(node, include_hidden=hidden_services(args))
    found = [name for name, types in found_all.items() if args.service_type in types]
    print(*([len(found)] if args.count_services else found), sep="\n")
    return 0
