"""``ros2 topic list [-t] | info [-v] | echo [--once] [-n N] | hz [--window N] [--duration S]
| pub TOPIC TYPE [VALUES] [--once | -t N] [-r HZ] [-w N] | find TYPE | bw TOPIC``."""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from typing import Any

import yaml
from builtin_interfaces.msg import Time
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import (
    QoSDurabilityPolicy,
    QoSHistoryPolicy,
    QoSPresetProfiles,
    QoSProfile,
    QoSReliabilityPolicy,
    qos_profile_sensor_data,
)
from std_msgs.msg import Header

from rosbook.cli import GRAPH_TIMEOUT_S, cli_node
from rosbook.cli.reporting import fail, reports_errors
from rosbook.runtime import graph
from rosbook.runtime.interfaces import InterfaceError, fill, message_class, to_yaml


def add_parser(verbs: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    parser = verbs.add_parser(
        "topic", help="Topics on the graph: list, info, echo, hz, pub, find, bw"
    )
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
    add_publishing_parsers(commands)


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


# -- pub, find, bw (as ros2topic's) -------------------------------------------------
#: How often ``topic pub`` looks for matching subscriptions, in seconds (as upstream).
MATCH_POLL_S = 0.1


def _positive_float(text: str) -> float:
    value = float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{text} is not a positive number")
    return value


def _nonnegative_int(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text} is not zero or more")
    return value


def add_publishing_parsers(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = commands.add_parser("pub", help="Publish a message to a topic")
    p.add_argument("topic_name", help="Name of the ROS topic to publish to (e.g. '/chatter')")
    p.add_argument("message_type", help="Type of the ROS message (e.g. 'std_msgs/msg/String')")
    p.add_argument(
        "values", nargs="?", default="{}", help="Values to fill the message with in YAML format"
    )
    p.add_argument(
        "-r",
        "--rate",
        metavar="N",
        type=_positive_float,
        default=1.0,
        help="Publishing rate in Hz (default: 1)",
    )
    p.add_argument(
        "-p",
        "--print",
        metavar="N",
        type=int,
        default=1,
        help="Only print every N-th published message (default: 1)",
    )
    times = p.add_mutually_exclusive_group()
    times.add_argument("-1", "--once", action="store_true", help="Publish one message and exit")
    times.add_argument(
        "-t",
        "--times",
        type=_nonnegative_int,
        default=0,
        help="Publish this number of times and then exit",
    )
    p.add_argument(
        "-w",
        "--wait-matching-subscriptions",
        type=_nonnegative_int,
        default=None,
        help="Wait until finding the specified number of matching subscriptions. "
        'Defaults to 1 when using "-1"/"--once"/"--times", otherwise defaults to 0.',
    )
    p.add_argument(
        "--max-wait-time-secs",
        type=_positive_float,
        default=None,
        help="Maximum wait time in seconds for the matching subscriptions",
    )
    p.add_argument(
        "--keep-alive",
        metavar="N",
        type=_positive_float,
        default=0.1,
        help="Keep publishing node alive for N seconds after the last msg",
    )
    p.add_argument("-n", "--node-name", help="Name of the created publishing node")
    p.add_argument(
        "--qos-profile",
        choices=QoSPresetProfiles.short_keys(),
        default="default",
        help="Quality of service preset profile to publish with (default: default)",
    )
    p.add_argument("--qos-depth", type=_nonnegative_int, default=None, help="Queue size")
    p.add_argument("--qos-history", choices=["system_default", "keep_last", "keep_all"])
    p.add_argument("--qos-reliability", choices=["system_default", "reliable", "best_effort"])
    p.add_argument("--qos-durability", choices=["system_default", "transient_local", "volatile"])
    p.set_defaults(func=pub)

    p = commands.add_parser("find", help="Output a list of available topics of a given type")
    p.add_argument("topic_type", help="Name of the ROS topic type (e.g. 'std_msgs/msg/String')")
    p.add_argument(
        "-c",
        "--count-topics",
        action="store_true",
        help="Only display the number of topics discovered",
    )
    p.add_argument(
        "--include-hidden-topics", action="store_true", help="Consider hidden topics as well"
    )
    p.set_defaults(func=find)

    p = commands.add_parser("bw", help="Display bandwidth used by topic")
    p.add_argument("topic", help="Topic name to monitor for bandwidth utilization")
    p.add_argument(
        "-w",
        "--window",
        type=int,
        default=100,
        metavar="WINDOW",
        help="maximum window size, in # of messages (default: 100)",
    )
    p.add_argument(
        "--duration", type=float, default=None, help="stop after S seconds (not in ros2)"
    )
    p.set_defaults(func=bw)


def _qos(args: argparse.Namespace) -> QoSProfile:
    """The preset ``--qos-profile`` with the ``--qos-*`` settings given on top (as upstream)."""
    profile = QoSPresetProfiles.get_from_short_key(args.qos_profile)
    if args.qos_history:
        profile.history = QoSHistoryPolicy.get_from_short_key(args.qos_history)
    if args.qos_reliability:
        profile.reliability = QoSReliabilityPolicy.get_from_short_key(args.qos_reliability)
    if args.qos_durability:
        profile.durability = QoSDurabilityPolicy.get_from_short_key(args.qos_durability)
    if args.qos_depth is not None:
        profile.depth = args.qos_depth
    return profile


def stamp_fields(message: Any, values: dict[str, Any]) -> list[Callable[[Time], None]]:
    """Take ``header: auto`` and ``stamp: now`` (any depth) out of ``values``: setters
    that put the time of each publication into those fields (``ros2 topic pub``'s
    ``expand_header_auto`` and ``expand_time_now``)."""
    setters: list[Callable[[Time], None]] = []
    for field, value in list(values.items()):
        current = getattr(message, field, None)
        if value == "auto" and isinstance(current, Header):
            del values[field]
            setters.append(lambda now, h=current: setattr(h, "stamp", now))
        elif value == "now" and isinstance(current, Time):
            del values[field]
            setters.append(lambda now, m=message, f=field: setattr(m, f, now))
        elif isinstance(value, dict) and hasattr(current, "get_fields_and_field_types"):
            setters += stamp_fields(current, value)
    return setters


@reports_errors
def pub(args: argparse.Namespace) -> int:
    times = 1 if args.once else args.times
    wanted = args.wait_matching_subscriptions
    wanted = int(times != 0) if wanted is None else wanted
    if wanted == 0 and args.max_wait_time_secs is not None:
        return fail(
            "--max-wait-time-secs option is only effective"
            " with --wait-matching-subscriptions, --once or --times"
        )
    try:
        msg_type = message_class(args.message_type)
    except InterfaceError:
        return fail("The passed message type is invalid")
    try:
        values = yaml.safe_load(args.values)
    except yaml.YAMLError as error:
        return fail(f"Failed to populate field: {error}")
    if not isinstance(values, dict):
        return fail("The passed value needs to be a dictionary in YAML format")
    msg = msg_type()
    try:
        setters = stamp_fields(msg, values)
        fill(msg, values)
    except InterfaceError as error:
        return fail(f"Failed to populate field: {error}")

    with cli_node(name=args.node_name) as node:
        publisher = node.create_publisher(msg_type, args.topic_name, _qos(args))
        waited = 0.0
        while publisher.get_subscription_count() < wanted:
            if round(waited / MATCH_POLL_S) % 10 == 0:  # a line a second, as upstream
                print(f"Waiting for at least {wanted} matching subscription(s)...", flush=True)
            if args.max_wait_time_secs is not None and waited >= args.max_wait_time_secs:
                return fail(
                    f"Timed out waiting for subscribers: Expected {wanted} subcribers but only"
                    f" got {publisher.get_subscription_count()} subscribers"
                )
            time.sleep(MATCH_POLL_S)  # a poll of the graph, as upstream's
            waited += MATCH_POLL_S
        print("publisher: beginning loop", flush=True)
        count = 0

        def publish() -> None:
            nonlocal count
            now = node.get_clock().now().to_msg()
            for setter in setters:
                setter(now)
            count += 1
            if args.print and count % args.print == 0:
                print(f"publishing #{count}: {msg!r}\n", flush=True)
            publisher.publish(msg)

        publish()
        if times != 1:
            timer = node.create_timer(1.0 / args.rate, publish)
            graph.wait_for(lambda _: 0 < times <= count, node, timeout=math.inf)
            node.destroy_timer(timer)
        # Reliable subscribers acknowledge what they got: the last message is not lost
        # when this process ends right after it (a guard, not a fixed wait).
        publisher.wait_for_all_acked(Duration(seconds=GRAPH_TIMEOUT_S))
        time.sleep(args.keep_alive)
    return 0


@reports_errors
def find(args: argparse.Namespace) -> int:
    with cli_node(settle=True) as node:
        topics = graph.topic_names_and_types(node, include_hidden=args.include_hidden_topics)
    found = [name for name, types in topics if args.topic_type in types]
    print(*([len(found)] if args.count_topics else found), sep="\n")
    return 0


def _size(num_bytes: float, bytes_per_s: float) -> str:
    """Bytes in the unit ``ros2 topic bw`` picks for a rate of ``bytes_per_s``."""
    if bytes_per_s < 1000:
        return f"{num_bytes:.0f} B"
    if bytes_per_s < 1000000:
        return f"{num_bytes / 1000:.2f} KB"
    return f"{num_bytes / 1000 / 1000:.2f} MB"


@reports_errors
def bw(args: argparse.Namespace) -> int:
    duration = math.inf if args.duration is None else args.duration
    topic = "/" + args.topic.lstrip("/")
    sizes: list[tuple[float, int]] = []  # (arrival, serialized size), the last WINDOW

    def record(data: bytes) -> None:
        sizes.append((time.monotonic(), len(data)))
        del sizes[: -args.window]

    with cli_node() as node:
        find_publisher(node, topic)
        info = graph.topic_info(topic, node)
        if not info.publishers:
            return fail("Could not determine the type for the passed topic")
        node.create_subscription(
            message_class(info.types[0]), topic, record, qos_profile_sensor_data, raw=True
        )
        print(f"Subscribed to [{topic}]", flush=True)
        start = time.monotonic()
        while (left := duration - (time.monotonic() - start)) > 0:
            graph.wait_for(lambda _: False, node, timeout=min(1.0, left))
            if len(sizes) < 2:
                continue
            window = [size for _, size in sizes]
            rate = sum(window) / (time.monotonic() - sizes[0][0])
            mean, low, high = (
                _size(s, rate) for s in (sum(window) / len(window), min(window), max(window))
            )
            print(
                f"{_size(rate, rate)}/s from {len(sizes)} messages\n"
                f"\tMessage size mean: {mean} min: {low} max: {high}",
                flush=True,
            )
    return 0
