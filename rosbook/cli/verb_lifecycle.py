"""``ros2 lifecycle nodes|get|set|list``: managed nodes' states and transitions, worded
as upstream's (ros2cli's ``ros2lifecycle``, jazzy).

A node is a lifecycle node when it offers ``<node>/get_state``
(``lifecycle_msgs/srv/GetState``); the verbs call its lifecycle services
(``get_state``, ``get_available_transitions``, ``get_transition_graph``,
``change_state``) from the command's own node.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from rclpy.node import Node

from rosbook.cli import GRAPH_TIMEOUT_S, add_strategy_arguments, cli_node
from rosbook.cli.reporting import fail, reports_errors
from rosbook.runtime import graph

#: The service type that makes a node a lifecycle node, as upstream tells them.
GET_STATE_TYPE = "lifecycle_msgs/srv/GetState"
#: What upstream prints (and exits 1 with) for a name that is no lifecycle node.
NODE_NOT_FOUND = "Node not found"
HIDDEN_HELP = "Consider hidden nodes as well"


def add_parser(verbs: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    parser = verbs.add_parser("lifecycle", help="Various lifecycle related sub-commands")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = commands.add_parser("get", help="Get lifecycle state for one or more nodes")
    add_strategy_arguments(p)
    p.add_argument(
        "node_name",
        nargs="?",
        help="Name of the ROS node. If no name is provided, then get the state for all nodes.",
    )
    p.add_argument("--include-hidden-nodes", action="store_true", help=HIDDEN_HELP)
    p.set_defaults(func=get)

    p = commands.add_parser("list", help="Output a list of available transitions")
    add_strategy_arguments(p)
    p.add_argument("node_name", help="Name of the ROS node")
    p.add_argument("--include-hidden-nodes", action="store_true", help=HIDDEN_HELP)
    p.add_argument("-a", "--all", action="store_true", help="Display all existing transitions")
    p.set_defaults(func=list_transitions)

    p = commands.add_parser("nodes", help="Output a list of nodes with lifecycle")
    add_strategy_arguments(p)
    p.add_argument("-a", "--all", action="store_true", help="Display all nodes even hidden ones")
    p.add_argument(
        "-c",
        "--count-nodes",
        action="store_true",
        help="Only display the number of nodes discovered",
    )
    p.set_defaults(func=nodes)

    p = commands.add_parser("set", help="Trigger lifecycle state transition")
    add_strategy_arguments(p)
    p.add_argument("node_name", help="Name of the ROS node")
    p.add_argument("--include-hidden-nodes", action="store_true", help=HIDDEN_HELP)
    p.add_argument("transition", help="The lifecycle transition")
    p.set_defaults(func=set_transition)


def lifecycle_node_names(node: Node, *, include_hidden: bool) -> list[str]:
    """Full names of the graph's lifecycle nodes, sorted, each as often as the graph has
    it (two nodes may share a name); hidden ones only if asked."""
    services = dict(node.get_service_names_and_types())
    return sorted(
        name
        for name in node.get_fully_qualified_node_names()
        if (include_hidden or not graph.is_hidden(name))
        and GET_STATE_TYPE in services.get(f"{name}/get_state", [])
    )


def _absolute(name: str) -> str:
    return name if name.startswith("/") else f"/{name}"


def _found(node: Node, name: str, include_hidden: bool) -> bool:
    """Whether ``name`` is a lifecycle node: as soon as discovery shows it, or no once
    the graph settled without it."""
    return graph.lookup(
        lambda g: name in lifecycle_node_names(g, include_hidden=include_hidden), node
    )


def _call(node: Node, srv_type: type, service: str, request: Any = None) -> Any:
    from rosbook.runtime.services import call

    return call(node, srv_type, service, request, timeout=GRAPH_TIMEOUT_S)


def _exception(node_name: str, error: Exception) -> str:
    return f"Exception while calling service of node '{node_name}': {error}"


@reports_errors
def nodes(args: argparse.Namespace) -> int:
    with cli_node(settle=True, args=args) as node:
        names = lifecycle_node_names(node, include_hidden=args.all)
    if args.count_nodes:
        print(len(names))
    elif names:
        print(*sorted(set(names)), sep="\n")
    return 0


@reports_errors
def get(args: argparse.Namespace) -> int:
    from lifecycle_msgs.srv import GetState

    from rosbook.runtime.services import ServiceCallError

    hidden = args.include_hidden_nodes
    with cli_node(settle=args.node_name is None, args=args) as node:
        if args.node_name:
            name = _absolute(args.node_name)
            if not _found(node, name, hidden):
                return fail(NODE_NOT_FOUND)
            queried = [name]
        else:
            queried = sorted(set(lifecycle_node_names(node, include_hidden=hidden)))
        states = {}
        for name in queried:
            try:
                states[name] = _call(node, GetState, f"{name}/get_state").current_state
            except ServiceCallError as error:
                print(_exception(name, error), file=sys.stderr)
                if args.node_name:
                    return 1
    for name, state in sorted(states.items()):
        prefix = "" if args.node_name else f"{name}: "
        print(f"{prefix}{state.label} [{state.id}]")
    return 0


@reports_errors
def list_transitions(args: argparse.Namespace) -> int:
    from lifecycle_msgs.srv import GetAvailableTransitions

    from rosbook.runtime.services import ServiceCallError

    name = _absolute(args.node_name)
    service = "get_transition_graph" if args.all else "get_available_transitions"
    with cli_node(args=args) as node:
        if not _found(node, name, args.include_hidden_nodes):
            return fail(NODE_NOT_FOUND)
        try:
            response = _call(node, GetAvailableTransitions, f"{name}/{service}")
        except ServiceCallError as error:
            return fail(_exception(args.node_name, error))
    for t in response.available_transitions:
        print(
            f"- {t.transition.label} [{t.transition.id}]\n"
            f"\tStart: {t.start_state.label}\n"
            f"\tGoal: {t.goal_state.label}"
        )
    return 0


@reports_errors
def set_transition(args: argparse.Namespace) -> int:
    from lifecycle_msgs.srv import ChangeState, GetAvailableTransitions

    from rosbook.runtime.services import ServiceCallError

    name = _absolute(args.node_name)
    with cli_node(args=args) as node:
        if not _found(node, name, args.include_hidden_nodes):
            return fail(NODE_NOT_FOUND)
        try:
            available = _call(
                node, GetAvailableTransitions, f"{name}/get_available_transitions"
            ).available_transitions
        except ServiceCallError as error:
            return fail(_exception(args.node_name, error))
        transitions = [t.transition for t in available]
        chosen = next((t for t in transitions if t.label == args.transition), None)
        if chosen is None:
            chosen = next((t for t in transitions if str(t.id) == args.transition), None)
        if chosen is None:
            return fail(
                "Unknown transition requested, available ones are:"
                + "".join(f"\n- {t.label} [{t.id}]" for t in transitions)
            )
        try:
            success = _call(
                node, ChangeState, f"{name}/change_state", ChangeState.Request(transition=chosen)
            ).success
        except ServiceCallError as error:
            print(_exception(args.node_name, error), file=sys.stderr)  # exit 0, as upstream
            return 0
    if success:
        print("Transitioning successful")
    else:
        print("Transitioning failed", file=sys.stderr)  # exit 0, as upstream
    return 0
