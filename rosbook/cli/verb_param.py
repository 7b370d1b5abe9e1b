"""``ros2 param list [NODE]``, ``ros2 param get NODE NAME``, ``ros2 param set NODE NAME VALUE``."""

from __future__ import annotations

import argparse
import array
import sys

from rcl_interfaces.msg import ParameterType
from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python

from rosbook.cli import GRAPH_TIMEOUT_S, cli_node
from rosbook.cli.reporting import fail
from rosbook.runtime import graph
from rosbook.runtime.graph import absolute_name
from rosbook.runtime.params import list_parameters, parameter_value, set_parameter
from rosbook.runtime.services import ServiceCallError

#: What ``ros2 param get`` prints before a value, by its ``ParameterType`` (upstream's).
LABELS = {
    ParameterType.PARAMETER_BOOL: "Boolean value is:",
    ParameterType.PARAMETER_INTEGER: "Integer value is:",
    ParameterType.PARAMETER_DOUBLE: "Double value is:",
    ParameterType.PARAMETER_STRING: "String value is:",
    ParameterType.PARAMETER_BYTE_ARRAY: "Byte values are:",
    ParameterType.PARAMETER_BOOL_ARRAY: "Boolean values are:",
    ParameterType.PARAMETER_INTEGER_ARRAY: "Integer values are:",
    ParameterType.PARAMETER_DOUBLE_ARRAY: "Double values are:",
    ParameterType.PARAMETER_STRING_ARRAY: "String values are:",
}


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
    """Upstream's layout: ``  name`` lines, under a ``/node:`` header only when listing
    every node (and only nodes that have parameters)."""
    with cli_node(settle=not args.node_name) as node:
        if args.node_name:
            targets = [absolute_name(args.node_name)]
            if not _serves_parameters(node, targets[0]):
                return fail("Node not found")
        else:
            own = node.get_fully_qualified_name()
            targets = sorted(
                name
                for name in node.get_fully_qualified_node_names()
                if name != own and not graph.is_hidden(name)
            )
        for target in targets:
            try:
                names = list_parameters(node, target, GRAPH_TIMEOUT_S)
            except ServiceCallError as exc:
                print(f"Exception while calling service of node '{target}': {exc}", file=sys.stderr)
                continue
            if not args.node_name and names:
                print(f"{target}:")
            for name in names:
                print(f"  {name}")
    return 0


def get_param(args: argparse.Namespace) -> int:
    target = absolute_name(args.node_name)
    with cli_node() as node:
        if not _serves_parameters(node, target):
            return fail("Node not found")
        try:
            value = parameter_value(node, target, args.parameter_name, GRAPH_TIMEOUT_S)
        except ServiceCallError as exc:
            return fail(str(exc))
    if value is None:
        return fail("Parameter not set")
    if value.type == ParameterType.PARAMETER_NOT_SET:
        print("Parameter not set.")
        return 0
    python = parameter_value_to_python(value)
    if isinstance(python, array.array):  # integer and double arrays
        python = python.tolist()
    print(LABELS[value.type], python)
    return 0


def set_param(args: argparse.Namespace) -> int:
    """As upstream: a refusal is reported on stderr, yet the exit code is 0."""
    target = absolute_name(args.node_name)
    with cli_node() as node:
        if not _serves_parameters(node, target):
            return fail("Node not found")
        try:
            result = set_parameter(node, target, args.parameter_name, args.value, GRAPH_TIMEOUT_S)
        except ServiceCallError as exc:
            return fail(str(exc))
    if result.successful:
        print("Set parameter successful" + (f": {result.reason}" if result.reason else ""))
    else:
        reason = f": {result.reason}" if result.reason else ""
        print(f"Setting parameter failed{reason}", file=sys.stderr)
    return 0
