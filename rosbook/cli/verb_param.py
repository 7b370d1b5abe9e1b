"""``ros2 param list [NODE]``, ``ros2 param get NODE NAME``, ``ros2 param set NODE NAME VALUE``."""

from __future__ import annotations

import argparse
import sys

from rclpy.node import Node

from rosbook.cli import GRAPH_TIMEOUT_S, cli_node
from rosbook.runtime import graph
from rosbook.runtime.graph import absolute_name
from rosbook.runtime.params import ParameterError, get_parameter, list_parameters, set_parameter
from rosbook.runtime.services import ServiceCallError

#: What ``ros2 param get`` prints before the value, by Python type.
LABELS = {bool: "Boolean", int: "Integer", float: "Double", str: "String"}


def add_parser(verbs: argparse._SubParsersAction) -> None:
    parser = verbs.add_parser("param", help="list, get and set node parameters")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    listing = commands.add_parser("list", help="the parameters of one node or of all")
    listing.add_argument("node_name", nargs="?")
    listing.set_defaults(func=list_params)
    getter = commands.add_parser("get", help="one parameter's value")
    getter.add_argument("node_name")
    getter.add_argument("parameter_name")
    getter.set_defaults(func=get_param)
    setter = commands.add_parser("set", help="set one parameter (the node may refuse)")
    setter.add_argument("node_name")
    setter.add_argument("parameter_name")
    setter.add_argument("value", help="read as YAML: 5 is an integer, 5.0 a double")
    setter.set_defaults(func=set_param)


def _serves_parameters(node: Node, target: str) -> bool:
    """Whether ``target``'s parameter services are on the graph: at once when they are,
    False once the graph settled without them."""
    service = f"{target.rstrip('/')}/get_parameters"
    return graph.lookup(lambda g: service in dict(g.get_service_names_and_types()), node)


def list_params(args: argparse.Namespace) -> int:
    with cli_node(settle=not args.node_name) as node:
        if args.node_name:
            targets = [absolute_name(args.node_name)]
        else:
            targets = sorted(
                ns.rstrip("/") + "/" + name
                for name, ns in node.get_node_names_and_namespaces()
                if not name.startswith("_")
            )
        status = 0
        for target in targets:
            try:
                if not _serves_parameters(node, target):
                    raise ServiceCallError(f"no node '{target}'")
                names = list_parameters(node, target, GRAPH_TIMEOUT_S)
            except ServiceCallError:
                print(f"ros2 param list: no node '{target}' answers", file=sys.stderr)
                status = 1
                continue
            print(f"{target}:")
            for name in names:
                print(f"  {name}")
    return status


def get_param(args: argparse.Namespace) -> int:
    target = absolute_name(args.node_name)
    with cli_node() as node:
        try:
            if not _serves_parameters(node, target):
                raise ServiceCallError(f"no node '{target}'")
            value = get_parameter(node, target, args.parameter_name, GRAPH_TIMEOUT_S)
        except ServiceCallError:
            print(f"ros2 param get: no node '{target}' answers", file=sys.stderr)
            return 1
        except ParameterError as exc:
            print(f"ros2 param get: {exc}", file=sys.stderr)
            return 1
    label = LABELS.get(type(value), "Array" if isinstance(value, list) else "Value")
    print(f"{label} value is: {value}")
    return 0


def set_param(args: argparse.Namespace) -> int:
    target = absolute_name(args.node_name)
    with cli_node() as node:
        try:
            if not _serves_parameters(node, target):
                raise ServiceCallError(f"no node '{target}'")
            result = set_parameter(node, target, args.parameter_name, args.value, GRAPH_TIMEOUT_S)
        except ServiceCallError:
            print(f"ros2 param set: no node '{target}' answers", file=sys.stderr)
            return 1
    if not result.successful:
        reason = result.reason or "refused"
        print(f"Setting parameter failed: {reason}", file=sys.stderr)
        return 1
    print("Set parameter successful")
    return 0
