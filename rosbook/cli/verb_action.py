"""``ros2 action list [-t]``, ``ros2 action info ACTION``, ``ros2 action type ACTION`` and
``ros2 action send_goal``."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable

from rclpy.action.graph import (
    get_action_client_names_and_types_by_node,
    get_action_names_and_types,
    get_action_server_names_and_types_by_node,
)
from rclpy.node import Node

from rosbook.cli import ADDITION, add_values_argument, cli_node, values
from rosbook.cli.reporting import fail
from rosbook.runtime import graph
from rosbook.runtime.actions import run_goal
from rosbook.runtime.interfaces import InterfaceError, from_yaml, message_class, to_yaml
from rosbook.runtime.services import ServiceCallError

#: A by-node action lookup of ``rclpy.action.graph``.
Lookup = Callable[[Node, str, str], list[tuple[str, list[str]]]]


def add_parser(verbs: argparse._SubParsersAction) -> None:
    parser = verbs.add_parser("action", help="list and inspect actions")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    listing = commands.add_parser("list", help="the actions of the running nodes")
    listing.add_argument("-t", "--show-types", action="store_true", help="show each type")
    listing.add_argument(
        "-c", "--count-actions", action="store_true", help="Only display the number of actions"
    )
    listing.set_defaults(func=list_actions)
    info = commands.add_parser("info", help="the servers and clients of an action")
    info.add_argument("action_name")
    info.add_argument("-t", "--show-types", action="store_true", help="show each type")
    info.add_argument(
        "-c", "--count", action="store_true", help="Only display the number of clients and servers"
    )
    info.set_defaults(func=action_info)
    goal = commands.add_parser("send_goal", help="send a goal and wait for its result")
    goal.add_argument("action_name")
    goal.add_argument("action_type", help="e.g. test_msgs/action/Fibonacci")
    add_values_argument(goal, "goal", "", "goal as YAML: '{order: 5}'")
    goal.add_argument("-f", "--feedback", action="store_true", help="print the feedback")
    goal.add_argument(
        "--timeout", type=float, default=math.inf, help=f"give up after S seconds {ADDITION}"
    )
    goal.set_defaults(func=send_goal)
    add_type_parser(commands)


def list_actions(args: argparse.Namespace) -> int:
    with cli_node(settle=True) as node:
        actions = get_action_names_and_types(node)
    if args.count_actions:
        print(len(actions))
        return 0
    for name, types in sorted(actions):
        print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return 0


def _users(node: Node, action: str, lookup: Lookup) -> list[tuple[str, list[str]]]:
    """(full name, types) of the nodes that ``lookup`` finds on ``action``: hidden ones
    too, as upstream, but never the CLI's own node."""
    found = []
    for name, namespace in node.get_node_names_and_namespaces():
        if namespace.rstrip("/") + "/" + name == node.get_fully_qualified_name():
            continue
        for action_name, types in lookup(node, name, namespace):
            if action_name == action:
                found.append((namespace.rstrip("/") + "/" + name, types))
    return sorted(found)


def action_info(args: argparse.Namespace) -> int:
    action = "/" + args.action_name.lstrip("/")
    with cli_node() as node:

        def users() -> tuple[list, list]:
            return (
                _users(node, action, get_action_client_names_and_types_by_node),
                _users(node, action, get_action_server_names_and_types_by_node),
            )

        # The action's name and the nodes behind it are discovered separately. As
        # upstream, an action nobody serves or uses is shown with no clients, no servers.
        if graph.lookup(lambda _: any(users()), node):
            graph.settle(node)
        clients, servers = users()
    print(f"Action: {action}")
    for title, users in (("Action clients", clients), ("Action servers", servers)):
        print(f"{title}: {len(users)}")
        for name, types in [] if args.count else users:
            print(f"    {name} [{', '.join(types)}]" if args.show_types else f"    {name}")
    return 0


def send_goal(args: argparse.Namespace) -> int:
    """Print as the real ``ros2 action send_goal`` does: goal, ID, feedback, result, status."""
    try:
        action_type = message_class(args.action_type)
    except InterfaceError:
        return fail("The passed action type is invalid")
    try:
        goal = from_yaml(action_type.Goal, values(args, "goal"))
    except InterfaceError as exc:
        return fail(f"Failed to populate message fields: {exc}")

    early: list[object] | None = []  # feedback that overtook the goal's acceptance

    def show(message: object) -> None:
        print(f"Feedback:\n    {to_yaml(message)}\n", flush=True)

    def accepted(goal_id: str) -> None:
        nonlocal early
        print(f"Goal accepted with ID: {goal_id}\n", flush=True)
        for message in early or []:
            show(message)
        early = None

    def feedback(message: object) -> None:
        if early is not None:
            early.append(message)
        else:
            show(message)

    action = "/" + args.action_name.lstrip("/")
    with cli_node() as node:
        print("Waiting for an action server to become available...")
        print(f"Sending goal:\n     {to_yaml(goal)}\n", flush=True)
        try:
            run = run_goal(
                node,
                action_type,
                action,
                goal,
                timeout=args.timeout,
                on_accepted=accepted,
                on_feedback=feedback if args.feedback else None,
            )
        except ServiceCallError as exc:
            print(f"ros2 action send_goal: {exc}", file=sys.stderr)
            return 1
        except KeyboardInterrupt:  # run_goal asked the server to cancel the goal
            print("Canceling goal...")
            return 0
    if not run.accepted:
        print("Goal was rejected.")
        return 1
    if run.result is None:
        print(
            f"ros2 action send_goal: no result from '{action}' within {args.timeout:g} s",
            file=sys.stderr,
        )
        return 1
    print(f"Result:\n    {to_yaml(run.result)}\n")
    print(f"Goal finished with status: {run.status_name}")
    return 0


def add_type_parser(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    kind = commands.add_parser("type", help="Print a action's type")
    kind.add_argument("action_name", help="Name of the ROS action (e.g. '/fibonacci')")
    kind.set_defaults(func=action_type)


def action_type(args: argparse.Namespace) -> int:
    """Each type of ``ACTION``, one a line; exit 1 and nothing printed if it is unknown
    (as upstream)."""
    with cli_node() as node:
        graph.lookup(lambda g: args.action_name in dict(get_action_names_and_types(g)), node)
        types = dict(get_action_names_and_types(node)).get(args.action_name)
    for type_name in types or []:
        print(type_name)
    return 0 if types else 1
