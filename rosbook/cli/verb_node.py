"""``ros2 node list [-a] [-c]`` and ``ros2 node info NODE``, worded as upstream's."""

from __future__ import annotations

import argparse
import sys

from rclpy.node import Node

from rosbook.cli import cli_node
from rosbook.cli.reporting import fail, reports_errors
from rosbook.runtime import graph

#: What upstream prints (on stderr) when two nodes share one full name.
DUPLICATES_WARNING = (
    "WARNING: Be aware that there are nodes in the graph that share an exact name, "
    "which can have unintended side effects."
)
#: What upstream's ``ros2 node info`` prints (on stderr) for such a name.
INFO_DUPLICATES_WARNING = (
    'There are {count} nodes in the graph with the exact name "{name}". '
    "You are seeing information about only one of them."
)


def add_parser(verbs: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    parser = verbs.add_parser("node", help="Nodes on the graph: list, info")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = commands.add_parser("list", help="Print the nodes on the graph")
    p.add_argument("-a", "--all", action="store_true", help="include hidden nodes")
    p.add_argument("-c", "--count-nodes", action="store_true", help="print only the count")
    p.set_defaults(func=list_nodes)

    p = commands.add_parser("info", help="Print a node's publishers, subscribers, services")
    p.add_argument("node_name")
    p.add_argument("--include-hidden", action="store_true", help="include hidden endpoints")
    p.set_defaults(func=info)


def node_names(node: Node, *, include_hidden: bool) -> list[str]:
    """Full names of the nodes on the graph, sorted, each as often as it is there (two
    nodes may share one name), never the CLI's own node, hidden ones if asked."""
    own = node.get_fully_qualified_name()
    return sorted(
        name
        for name in node.get_fully_qualified_node_names()
        if name != own and (include_hidden or not graph.is_hidden(name))
    )


@reports_errors
def list_nodes(args: argparse.Namespace) -> int:
    with cli_node(settle=True) as node:
        names = node_names(node, include_hidden=args.all)
    if args.count_nodes:
        print(len(names))
    elif names:
        if len(set(names)) < len(names):
            print(DUPLICATES_WARNING, file=sys.stderr)
        print(*names, sep="\n")
    return 0


@reports_errors
def info(args: argparse.Namespace) -> int:
    full = "/" + args.node_name.lstrip("/")
    with cli_node() as node:

        def found(observer: Node) -> bool:
            return full in node_names(observer, include_hidden=args.include_hidden)

        if not graph.lookup(found, node):
            return fail(f"Unable to find node '{full}'")
        graph.settle(node)  # all of its endpoints
        count = node_names(node, include_hidden=args.include_hidden).count(full)
        if count > 1:
            print(INFO_DUPLICATES_WARNING.format(count=count, name=full), file=sys.stderr)
        print(graph.node_info(full, node, include_hidden=args.include_hidden).format())
    return 0
