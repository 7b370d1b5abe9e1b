"""``ros2 action list [-t]`` and ``ros2 action info ACTION``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from rclpy.action.graph import (
    get_action_client_names_and_types_by_node,
    get_action_names_and_types,
    get_action_server_names_and_types_by_node,
)
from rclpy.node import Node

from rosbook.cli import cli_node
from rosbook.cli.discovery import SETTLE_S, settle, wait_for

#: A by-node action lookup of ``rclpy.action.graph``.
Lookup = Callable[[Node, str, str], list[tuple[str, list[str]]]]


def add_parser(verbs: argparse._SubParsersAction) -> None:
    parser = verbs.add_parser("action", help="list and inspect actions")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    listing = commands.add_parser("list", help="the actions of the running nodes")
    listing.add_argument("-t", "--show-types", action="store_true", help="show each type")
    listing.set_defaults(func=list_actions)
    info = commands.add_parser("info", help="the servers and clients of an action")
    info.add_argument("action_name")
    info.add_argument("-t", "--show-types", action="store_true", help="show each type")
    info.set_defaults(func=action_info)


def list_actions(args: argparse.Namespace) -> int:
    with cli_node(discovery_s=0) as node:
        settle(node)
        actions = get_action_names_and_types(node)
    for name, types in sorted(actions):
        print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return 0


def _users(node: Node, action: str, lookup: Lookup) -> list[tuple[str, list[str]]]:
    """(full name, types) of the visible nodes that ``lookup`` finds on ``action``."""
    found = []
    for name, namespace in node.get_node_names_and_namespaces():
        if name.startswith("_"):
            continue
        for action_name, types in lookup(node, name, namespace):
            if action_name == action:
                found.append((namespace.rstrip("/") + "/" + name, types))
    return sorted(found)


def action_info(args: argparse.Namespace) -> int:
    action = "/" + args.action_name.lstrip("/")
    with cli_node(discovery_s=0) as node:

        def users() -> tuple[list, list]:
            return (
                _users(node, action, get_action_client_names_and_types_by_node),
                _users(node, action, get_action_server_names_and_types_by_node),
            )

        # The action's name and the nodes behind it are discovered separately.
        if wait_for(lambda: any(users())):
            settle(node, timeout=SETTLE_S * 4)
        if action not in dict(get_action_names_and_types(node)):
            print(f"ros2 action info: no action '{action}' is running", file=sys.stderr)
            return 1
        clients, servers = users()
    print(f"Action: {action}")
    for title, users in (("Action clients", clients), ("Action servers", servers)):
        print(f"{title}: {len(users)}")
        for name, types in users:
            print(f"    {name} [{', '.join(types)}]" if args.show_types else f"    {name}")
    return 0
