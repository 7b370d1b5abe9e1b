"""``ros2 topic list [-t] | info [-v] | echo [--once] [-n N] | hz [--window N] [--duration S]``."""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

from rosbook import graph
from rosbook.cli import DISCOVERY_S, cli_node
from rosbook.cli.reporting import fail, reports_errors
from rosbook.interfaces import to_yaml

#: Seconds a command waits for a named topic's publisher to be discovered.
WAIT_S = graph.ANNOUNCE_PERIOD_S


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
    with cli_node() as node:
        graph.topic_info(args.topic_name, node, wait=WAIT_S)  # GraphError if it never appears
        graph.settle(node, at_least=graph.ANNOUNCE_PERIOD_S - DISCOVERY_S)
        print(graph.topic_info(args.topic_name, node).format(verbose=args.verbose))
    return 0


@reports_errors
def echo(args: argparse.Namespace) -> int:
    count = 1 if args.once else (args.max_count if args.max_count is not None else math.inf)
    timeout = math.inf if args.timeout is None else args.timeout

    def show(msg: Any) -> None:
        print(to_yaml(msg), "---", sep="\n", flush=True)

    with cli_node() as node:
        got = graph.echo(
            args.topic_name, count, node, timeout=timeout, on_message=show, wait=WAIT_S
        )  # type: ignore[arg-type]
    if len(got) < count:
        topic = "/" + args.topic_name.lstrip("/")
        return fail(f"{len(got)} of {count:g} message(s) on '{topic}' in {timeout:g} s")
    return 0


@reports_errors
def hz(args: argparse.Namespace) -> int:
    duration = math.inf if args.duration is None else args.duration
    with cli_node() as node:
        monitor = graph.HzMonitor(args.topic_name, node, window=args.window, wait=WAIT_S)
        start = time.monotonic()
        try:
            while (left := duration - (time.monotonic() - start)) > 0:
                graph.wait_for(lambda _: False, node, timeout=min(1.0, left))
                rate = monitor.rate()
                print(rate.format() if rate else "no new messages", flush=True)
        finally:
            monitor.close()
    if monitor.rate() is None:
        return fail(
            f"topic '{monitor.topic}': too few messages in {duration:g} s to measure a rate"
        )
    return 0
