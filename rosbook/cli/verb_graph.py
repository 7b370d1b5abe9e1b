"""``ros2 graph [--svg FILE]``: the rqt_graph picture of the live graph (not in ros2)."""

from __future__ import annotations

import argparse
from pathlib import Path

from rosbook.cli import cli_node
from rosbook.cli.reporting import reports_errors
from rosbook.viz.graph_svg import collect, to_svg


def add_parser(verbs: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = verbs.add_parser(
        "graph",
        help="Print the graph's edges, or draw it as SVG (stands in for rqt_graph; "
        "this book's addition: not in ros2)",
    )
    p.add_argument("--svg", type=Path, default=None, help="write the picture to this file")
    p.add_argument("--include-hidden", action="store_true", help="include hidden nodes, topics")
    p.add_argument(
        "--include-debug", action="store_true", help="include /rosout and /parameter_events"
    )
    p.set_defaults(func=draw)


@reports_errors
def draw(args: argparse.Namespace) -> int:
    with cli_node(settle=True) as node:
        edges = collect(node, include_hidden=args.include_hidden, include_debug=args.include_debug)
    if args.svg is not None:
        args.svg.write_text(to_svg(edges) + "\n")
        print(f"wrote {args.svg}: {len(edges.nodes)} nodes, {len(edges.topics)} topics")
        return 0
    for (_, source), (_, target) in edges.edges:
        print(f"{source} -> {target}")
    return 0
