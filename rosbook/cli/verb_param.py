"""``ros2 param list [NODE]``, ``ros2 param get NODE NAME``, ``ros2 param set NODE NAME VALUE``,
``ros2 param dump NODE``, ``ros2 param load NODE FILE``."""

from __future__ import annotations

import argparse
import array
import sys
from typing import Any

import yaml
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.node import Node
from rclpy.parameter import (
    PARAMETER_SEPARATOR_STRING,
    parameter_dict_from_yaml_file,
    parameter_value_to_python,
)

from rosbook.cli import GRAPH_TIMEOUT_S, cli_node
from rosbook.cli.reporting import fail
from rosbook.runtime import graph
from rosbook.runtime.graph import absolute_name
from rosbook.runtime.params import (
    list_parameters,
    parameter_value,
    set_parameter,
)
from rosbook.runtime.services import ServiceCallError, call

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
    parser = verbs.add_parser("param", help="list, get, set, dump and load node parameters")
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
    add_file_parsers(commands)


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


# -- dump, load (as ros2param's) ----------------------------------------------------
def add_file_parsers(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    dump = commands.add_parser("dump", help="Show all of the parameters of a node as YAML")
    dump.add_argument("node_name", help="Name of the ROS node")
    dump.set_defaults(func=dump_params)
    load = commands.add_parser("load", help="Load parameter file for a node")
    load.add_argument("node_name", help="Name of the ROS node")
    load.add_argument("parameter_file", help="Parameter file")
    load.add_argument(
        "--no-use-wildcard",
        action="store_true",
        help="Do not load parameters in the '/**' namespace into the node",
    )
    load.set_defaults(func=load_params)


def _nest(tree: dict[str, Any], name: str, value: Any) -> None:
    """Put ``a.b.c``'s value at ``tree[a][b][c]``, as a parameter file holds it."""
    head, dot, rest = name.partition(PARAMETER_SEPARATOR_STRING)
    if dot:
        _nest(tree.setdefault(head, {}), rest, value)
    else:
        tree[name] = value


def dump_params(args: argparse.Namespace) -> int:
    target = absolute_name(args.node_name)
    with cli_node() as node:
        if not _serves_parameters(node, target):
            return fail("Node not found")
        try:
            names = list_parameters(node, target, GRAPH_TIMEOUT_S)
            request = GetParameters.Request(names=names)
            service = f"{target.rstrip('/')}/get_parameters"
            response = call(node, GetParameters, service, request, timeout=GRAPH_TIMEOUT_S)
        except ServiceCallError as error:
            print(f"Exception while calling service of node '{target}': {error}", file=sys.stderr)
            return 1
    tree: dict[str, Any] = {}
    for name, value in zip(names, response.values):
        _nest(tree, name, parameter_value_to_python(value))
    print(yaml.dump({target: {"ros__parameters": tree}}, default_flow_style=False))
    return 0


def load_params(args: argparse.Namespace) -> int:
    target = absolute_name(args.node_name)
    with cli_node() as node:
        if not _serves_parameters(node, target):
            return fail("Node not found")
        try:
            parameters = list(
                parameter_dict_from_yaml_file(
                    args.parameter_file, not args.no_use_wildcard, target_nodes=[target]
                ).values()
            )
        except (OSError, RuntimeError, yaml.YAMLError) as error:
            print(f"ros2 param load: {error}", file=sys.stderr)
            return 1
        request = SetParameters.Request(parameters=parameters)
        service = f"{target.rstrip('/')}/set_parameters"
        try:
            response = call(node, SetParameters, service, request, timeout=GRAPH_TIMEOUT_S)
        except ServiceCallError as error:
            print(f"ros2 param load: {error}", file=sys.stderr)
            return 1
    for parameter, result in zip(parameters, response.results):
        verdict = "successful" if result.successful else "failed"
        reason = f": {result.reason}" if result.reason else ""
        # A refused parameter is reported, not an error: exit 0 as upstream.
        print(
            f"Set parameter {parameter.name} {verdict}{reason}",
            file=sys.stdout if result.successful else sys.stderr,
        )
    return 0
