"""A ``ros2``-style command line for the parts of the ROS 2 CLI this book uses.

There is no ``ros2`` CLI wheel, so the project provides the verbs the book and labs
need on top of rclpy. Each verb lives in its own module ``rosbook/cli/verb_<name>.py``
that defines ``add_parser(verbs)``: it registers ``ros2 <name> ...`` on the argparse
sub-parsers ``verbs`` and sets ``func=handler`` with ``handler(args) -> int``. The
command is installed as ``ros2`` in the project's venv and also runs as
``python -m rosbook.cli``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import sys
from collections.abc import Iterator
from contextlib import contextmanager

import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from rosbook import graph

#: Wall time a fresh CLI node waits for discovery before it reads the graph
#: (the real ``ros2`` CLI keeps a daemon running for this; we start cold each time).
DISCOVERY_S = 0.5
#: Longest a verb waits for what it looks for (a service, an action's nodes, a
#: parameter service's answer), in seconds of wall time.
GRAPH_TIMEOUT_S = 5.0


@contextmanager
def cli_node(discovery_s: float = DISCOVERY_S, *, settle: bool = False) -> Iterator[Node]:
    """A short-lived, hidden node in a context of its own.

    It first spins ``discovery_s`` so that discovery can start. With ``settle`` (for
    listings of the whole graph) it instead waits until discovery found nothing new for
    a while, and at least one participant announcement period
    (``rosbook.graph.settle``). Its name starts with an underscore, like the real
    CLI's ``_ros2cli_*`` nodes, so graph listings leave it out by default.
    """
    context = Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    node = Node(f"_ros2cli_{os.getpid()}", context=context, start_parameter_services=False)
    try:
        if settle:
            graph.settle(node, at_least=graph.ANNOUNCE_PERIOD_S)
        else:
            graph.wait_for(lambda _: False, node, timeout=discovery_s)
        yield node
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ros2",
        description="The ros2 verbs this book uses, built on rclpy (see `ros2 VERB -h`).",
    )
    verbs = parser.add_subparsers(dest="verb", required=True, metavar="VERB")
    for module in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if module.name.startswith("verb_"):
            importlib.import_module(f"{__name__}.{module.name}").add_parser(verbs)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        return 0


if __name__ == "__main__":
    sys.exit(main())
