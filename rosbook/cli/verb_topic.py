"""``ros2 topic list [-t] | info [-v] | echo [--once] [-n N] | hz [--window N] [--duration S]``."""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

from rclpy.node import Node

from rosbook.cli import cli_node
from rosbook.cli.reporting import fail, reports_errors
from rosbook.runtime import graph
from rosbook.runtime.interfaces import to_yaml


def add_parser(verbs: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    parser = verbs.add_parser("topic", help="Topics on the graph: list, info, echo, hz")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = commands.add_parser("list", help="Print the topics on the graph")
    p.add_argument("-t", "--show-types", action="store_true", help="also print each type")
    p.add_argument("-c", "--count-topics", action="store_true", help="print only the count")
    p.add_argument("--include-hidden-topics", action="store_true", help="include hidden topics")
    p.set_defaults(func=list_topics)

    p = commands.add_parser("info", help="Print a topic's type and endpoints")
    p.add_argument("topic_name")
    p.add_argument("-v", "--verbose", action="store_true", help="every endpoint with its QoS")
    p.set_defaults(func=info)

    p = commands.add_parser("echo", help="Print the messages published on a topic")
    p.add_argument("topic_name")
    p.add_argument("--once", action="store_true", help="print one message and exit")
    p.add_argument("-n", "--max-count", type=int, default=None, help="exit after N messages")
    p.add_argument(
        "--timeout", type=float, default=None, help="give up after S seconds (not in ros2)"
    )
    p.set_defaults(func=echo)

    p = commands.add_parser("hz", help="Print the average publishing rate of a topic")
    p.add_argument("topic_name")
    p.add_argument("-w", "--window", type=int, default=10_000, help="intervals averaged")
    p.add_argument(
        "--duration", type=float, default=None, help="stop after S seconds (not in ros2)"
    )
    p.set_defaults(func=hz)


def find_publisher(node: Node, topic: str) -> bool:
    """Wait until a publisher of ``topic`` is discovered, or the graph settled without
    one; whether the topic is on the graph at all. When it is not, this prints the
    warning upstream's ``ros2 topic echo`` prints (on stdout); a topic with
    subscriptions only is left to ``graph.echo``/``HzMonitor``, which say so."""
    name = "/" + topic.lstrip("/")
    if graph.lookup(lambda g: g.count_publishers(name) > 0, node):
        graph.settle(node)  # all of its publishers, for a QoS that matches them all
        return True
    if name in dict(node.get_topic_names_and_types()):
        return True
    print(f"WARNING: topic [{name}] does not appear to be published yet", flush=True)
    return False


@reports_errors
def list_topics(args: argparse.Namespace) -> int:
    with cli_node(settle=True) as node:
        topics = graph.topic_names_and_types(node, include_hidden=args.include_hidden_topics)
    if args.count_topics:
        print(len(topics))
    for name, types in topics if not args.count_topics else []:
        print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return 0


@reports_errors
def info(args: argparse.Namespace) -> int:
    topic = "/" + args.topic_name.lstrip("/")
    with cli_node() as node:
        if not graph.lookup(lambda g: topic in dict(g.get_topic_names_and_types()), node):
            return fail(f"Unknown topic '{topic}'")  # upstream's words
        graph.settle(node)  # every endpoint of it, each with its node's name
        print(graph.topic_info(topic, node).format(verbose=args.verbose))
    return 0


@reports_errors
def echo(args: argparse.Namespace) -> int:
    count = 1 if args.once else (args.max_count if args.max_count is not None else math.inf)
    timeout = math.inf if args.timeout is None else args.timeout

    def show(msg: Any) -> None:
        print(to_yaml(msg), "---", sep="\n", flush=True)

    with cli_node() as node:
        if not find_publisher(node, args.topic_name):
            return fail("Could not determine the type for the passed topic")
        got = graph.echo(args.topic_name, count, node, timeout=timeout, on_message=show)
    if len(got) < count:
        topic = "/" + args.topic_name.lstrip("/")
        return fail(f"{len(got)} of {count:g} message(s) on '{topic}' in {timeout:g} s")
    return 0


@reports_errors
def hz(args: argparse.Namespace) -> int:
    duration = math.inf if args.duration is None else args.duration
    with cli_node() as node:
        if not find_publisher(node, args.topic_name):
            return fail("Could not determine the type for the passed topic")
        monitor = graph.HzMonitor(args.topic_name, node, window=args.window)
        start = time.monotonic()
        printed = None  # the newest stamp of the last rate printed
        try:
            while (left := duration - (time.monotonic() - start)) > 0:
                graph.wait_for(lambda _: False, node, timeout=min(1.0, left))
                rate = monitor.rate()
                # as upstream: nothing until there is a rate, nothing without new messages
                if rate is not None and monitor.times[-1] != printed:
                    printed = monitor.times[-1]
                    print(rate.format(), flush=True)
        finally:
            monitor.close()
    if monitor.rate() is None:
        return fail(
            f"topic '{monitor.topic}': too few messages in {duration:g} s to measure a rate"
        )
    return 0
