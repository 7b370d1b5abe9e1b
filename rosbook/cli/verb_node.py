"""``ros2 node list [-a] [-c]`` and ``ros2 node info NODE``."""

from __future__ import annotations

import argparse

from rosbook.cli import cli_node
from rosbook.cli.reporting import reports_errors
from rosbook.runtime import graph


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


@reports_errors
def list_nodes(args: argparse.Namespace) -> int:
    with cli_node(settle=True) as node:
        names = graph.node_names(node, include_hidden=args.all)
    if args.count_nodes:
        print(len(names))
    for name in [] if args.count_nodes else names:
        print(name)
    return 0


@reports_errors
def info(args: argparse.Namespace) -> int:
    full = "/" + args.node_name.lstrip("/")
    with cli_node() as node:
        if graph.lookup(lambda g: full in g.get_fully_qualified_node_names(), node):
            graph.settle(node)  # all of its endpoints
        print(graph.node_info(full, node, include_hidden=args.include_hidden).format())
    return 0
