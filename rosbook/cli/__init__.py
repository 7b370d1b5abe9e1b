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
import time
from collections.abc import Iterator
from contextlib import contextmanager

import rclpy
import rclpy.executors
from rclpy.context import Context
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

#: Wall time a fresh CLI node waits for discovery before it reads the graph
#: (the real ``ros2`` CLI keeps a daemon running for this; we start cold each time).
DISCOVERY_S = 0.5


@contextmanager
def cli_node(discovery_s: float = DISCOVERY_S) -> Iterator[Node]:
    """A short-lived, hidden node in a context of its own, after discovery settled.

    Its name starts with an underscore, like the real CLI's ``_ros2cli_*`` nodes, so
    graph listings leave it out by default.
    """
    context = Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    node = Node(f"_ros2cli_{os.getpid()}", context=context, start_parameter_services=False)
    try:
        executor = rclpy.executors.SingleThreadedExecutor(context=context)
        executor.add_node(node)
        deadline = time.monotonic() + discovery_s
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        executor.remove_node(node)
        executor.shutdown(timeout_sec=0)
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
