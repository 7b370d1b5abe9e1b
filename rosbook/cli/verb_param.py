"""``ros2 param list [NODE] | get | set | delete | describe | dump | load``, with
upstream's (ros2cli jazzy) options and output."""

from __future__ import annotations

import argparse
import array
import re
import sys
from collections.abc import Callable
from typing import Any, TypeVar

import yaml
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.node import Node
from rclpy.parameter import (
    PARAMETER_SEPARATOR_STRING,
    parameter_dict_from_yaml_file,
    parameter_value_to_python,
)

from rosbook.cli import GRAPH_TIMEOUT_S, add_strategy_arguments, cli_node
from rosbook.cli.reporting import fail, reports_errors
from rosbook.runtime import graph
from rosbook.runtime.graph import GraphError, absolute_name
from rosbook.runtime.params import (
    describe_parameters,
    list_parameters,
    parameter_value,
    set_parameter,
)
from rosbook.runtime.services import ServiceCallError, call

T = TypeVar("T")

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


#: How ``ros2 param list --param-type`` and ``describe`` name a ``ParameterType`` (upstream's).
TYPE_NAMES = {
    ParameterType.PARAMETER_BOOL: "boolean",
    ParameterType.PARAMETER_INTEGER: "integer",
    ParameterType.PARAMETER_DOUBLE: "double",
    ParameterType.PARAMETER_STRING: "string",
    ParameterType.PARAMETER_BYTE_ARRAY: "byte array",
    ParameterType.PARAMETER_BOOL_ARRAY: "boolean array",
    ParameterType.PARAMETER_INTEGER_ARRAY: "integer array",
    ParameterType.PARAMETER_DOUBLE_ARRAY: "double array",
    ParameterType.PARAMETER_STRING_ARRAY: "string array",
    ParameterType.PARAMETER_NOT_SET: "not set",
}


def _node_command(
    commands: argparse._SubParsersAction,  # type: ignore[type-arg]
    name: str,
    help: str,
    *,
    timeout: bool = True,
    every_node: bool = False,
) -> argparse.ArgumentParser:
    """A command on one node, with upstream's common options: the strategy ones,
    ``node_name`` (optional with ``every_node``), ``--include-hidden-nodes`` and
    (``timeout``) ``--timeout``."""
    parser = commands.add_parser(name, help=help)
    add_strategy_arguments(parser)
    parser.add_argument("node_name", nargs="?" if every_node else None, help="Name of the ROS node")
    parser.add_argument(
        "--include-hidden-nodes", action="store_true", help="Consider hidden nodes as well"
    )
    if timeout:
        parser.add_argument(
            "--timeout",
            metavar="N",
            type=int,
            default=None,
            help="Wait for N seconds until node is found; without it, until discovery has "
            "settled (upstream: default 1)",
        )
    return parser


def add_parser(verbs: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    parser = verbs.add_parser("param", help="list, get, set, dump and load node parameters")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    listing = _node_command(
        commands, "list", "Output a list of available parameters", timeout=False, every_node=True
    )
    listing.add_argument(
        "--filter", nargs=1, help="Only list parameters whose name matches this regular expression"
    )
    listing.add_argument(
        "--param-prefixes",
        nargs="+",
        default=[],
        help="Only list parameters with the provided prefixes",
    )
    listing.add_argument(
        "--param-type", action="store_true", help="Print parameter types with parameter names"
    )
    listing.set_defaults(func=list_params)
    getter = _node_command(commands, "get", "Get parameter")
    getter.add_argument("parameter_name", help="Name of the parameter")
    getter.add_argument("--hide-type", action="store_true", help="Hide the type information")
    getter.set_defaults(func=get_param)
    setter = _node_command(commands, "set", "Set parameter")
    setter.add_argument("parameter_name", help="Name of the parameter")
    setter.add_argument("value", help="read as YAML: 5 is an integer, 5.0 a double")
    setter.set_defaults(func=set_param)
    deleter = _node_command(commands, "delete", "Delete parameter")
    deleter.add_argument("parameter_name", help="Name of the parameter")
    deleter.set_defaults(func=delete_param)
    describer = _node_command(
        commands, "describe", "Show descriptive information about declared parameters"
    )
    describer.add_argument("parameter_names", nargs="+", help="Names of the parameters")
    describer.set_defaults(func=describe_params)
    add_file_parsers(commands)


def _target(node: Node, args: argparse.Namespace) -> str | None:
    """The absolute name of ``args.node_name`` when it serves parameters (waiting up to
    ``--timeout`` when given); None, as upstream's "Node not found", otherwise or when it
    is hidden and ``--include-hidden-nodes`` was not given."""
    target = absolute_name(args.node_name)
    if graph.is_hidden(target) and not args.include_hidden_nodes:
        return None
    timeout = getattr(args, "timeout", None)
    return target if _serves_parameters(node, target, timeout) else None


def _serves_parameters(node: Node, target: str, timeout: float | None = None) -> bool:
    """Whether ``target``'s parameter services are on the graph: at once when they are,
    False once the graph settled without them (or ``timeout`` s passed)."""
    service = f"{target.rstrip('/')}/get_parameters"
    limit = graph.SETTLE_TIMEOUT_S if timeout is None else timeout
    return graph.lookup(
        lambda g: service in dict(g.get_service_names_and_types()), node, timeout=limit
    )


def list_params(args: argparse.Namespace) -> int:
    """Upstream's layout: ``  name`` lines (``  name (type: T)`` with ``--param-type``),
    under a ``/node:`` header only when listing every node (and only nodes that have
    parameters); ``--filter`` keeps names its regular expression matches at their start."""
    pattern = re.compile(args.filter[0]) if args.filter else None
    with cli_node(settle=not args.node_name, args=args) as node:
        if args.node_name:
            target = _target(node, args)
            if target is None:
                return fail("Node not found")
            targets = [target]
        else:
            own = node.get_fully_qualified_name()
            targets = sorted(
                name
                for name in node.get_fully_qualified_node_names()
                if name != own and (args.include_hidden_nodes or not graph.is_hidden(name))
            )
        for target in targets:
            try:
                names = list_parameters(node, target, GRAPH_TIMEOUT_S, args.param_prefixes)
                names = [n for n in names if pattern is None or pattern.match(n)]
                types = {}
                if args.param_type and names:
                    described = describe_parameters(node, target, names, GRAPH_TIMEOUT_S)
                    types = {d.name: TYPE_NAMES[d.type] for d in described}
            except ServiceCallError as exc:
                print(f"Exception while calling service of node '{target}': {exc}", file=sys.stderr)
                continue
            if not args.node_name and names:
                print(f"{target}:")
            for name in names:
                print(f"  {name} (type: {types[name]})" if args.param_type else f"  {name}")
    return 0


def _answer(args: argparse.Namespace, request: Callable[[Node, str], T]) -> T:
    """``request(node, target)`` on the node ``args`` names: ``GraphError`` with upstream's
    "Node not found" when it is not there, with the call's error when that fails."""
    with cli_node(args=args) as node:
        target = _target(node, args)
        if target is None:
            raise GraphError("Node not found")
        try:
            return request(node, target)
        except ServiceCallError as exc:
            raise GraphError(str(exc)) from None


@reports_errors
def get_param(args: argparse.Namespace) -> int:
    value = _answer(
        args,
        lambda node, target: parameter_value(node, target, args.parameter_name, GRAPH_TIMEOUT_S),
    )
    if value is None:
        return fail("Parameter not set")
    if value.type == ParameterType.PARAMETER_NOT_SET:
        print("None" if args.hide_type else "Parameter not set.")
        return 0
    python = parameter_value_to_python(value)
    if isinstance(python, array.array):  # integer and double arrays
        python = python.tolist()
    if args.hide_type:
        print(python)
    else:
        print(LABELS[value.type], python)
    return 0


def _set(args: argparse.Namespace, value: Any, done: str, failed: str) -> int:
    """Set ``args.parameter_name`` to ``value`` (None: unset it) and print the node's
    verdict as upstream: ``done`` on stdout, or ``failed`` on stderr yet exit code 0."""
    result = _answer(
        args,
        lambda node, target: set_parameter(
            node, target, args.parameter_name, value, GRAPH_TIMEOUT_S
        ),
    )
    reason = f": {result.reason}" if result.reason else ""
    if result.successful:
        print(done + reason)
    else:
        print(failed + reason, file=sys.stderr)
    return 0


@reports_errors
def set_param(args: argparse.Namespace) -> int:
    """As upstream: a refusal is reported on stderr, yet the exit code is 0."""
    return _set(args, args.value, "Set parameter successful", "Setting parameter failed")


@reports_errors
def delete_param(args: argparse.Namespace) -> int:
    """Unset a parameter (its value set to "not set"); a refusal goes to stderr, exit 0."""
    return _set(args, None, "Deleted parameter successfully", "Deleting parameter failed")


@reports_errors
def describe_params(args: argparse.Namespace) -> int:
    """Each parameter's name, type, description and constraints, as upstream prints them."""
    found = _answer(
        args,
        lambda node, target: describe_parameters(
            node, target, args.parameter_names, GRAPH_TIMEOUT_S
        ),
    )
    for descriptor in found:
        print("Parameter name:", descriptor.name)
        print("  Type:", TYPE_NAMES[descriptor.type])
        if descriptor.description:
            print("  Description:", descriptor.description)
        print("  Constraints:")
        if descriptor.read_only:
            print("    Read only: true")
        ranges = list(descriptor.floating_point_range) + list(descriptor.integer_range)
        if ranges:
            print("    Min value:", ranges[0].from_value)
            print("    Max value:", ranges[0].to_value)
            if ranges[0].step:
                print("    Step:", ranges[0].step)
        if descriptor.additional_constraints:
            print("    Additional constraints:", descriptor.additional_constraints)
    return 0


# -- dump, load (as ros2param's) ----------------------------------------------------
def add_file_parsers(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    dump = _node_command(commands, "dump", "Show all of the parameters of a node as YAML")
    dump.set_defaults(func=dump_params)
    load = _node_command(commands, "load", "Load parameter file for a node")
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
    with cli_node(args=args) as node:
        target = _target(node, args)
        if target is None:
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
    with cli_node(args=args) as node:
        target = _target(node, args)
        if target is None:
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
