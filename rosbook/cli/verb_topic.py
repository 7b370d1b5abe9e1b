"""``ros2 topic list | type | info | echo | hz | pub | find | bw | delay``, with upstream's
(ros2cli jazzy) options and output; the few options this book adds say so in their help
(``ADDITION``)."""

from __future__ import annotations

import argparse
import copy
import math
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import yaml
from builtin_interfaces.msg import Time
from rclpy.duration import Duration
from rclpy.event_handler import SubscriptionEventCallbacks, UnsupportedEventTypeError
from rclpy.node import Node
from rclpy.qos import (
    QoSDurabilityPolicy,
    QoSHistoryPolicy,
    QoSLivelinessPolicy,
    QoSPresetProfiles,
    QoSProfile,
    QoSReliabilityPolicy,
    qos_profile_sensor_data,
)
from rclpy.time import Time as RosTime
from std_msgs.msg import Header

from rosbook.cli import (
    ADDITION,
    GRAPH_TIMEOUT_S,
    add_direct_arguments,
    add_message_format_arguments,
    add_strategy_arguments,
    add_values_argument,
    cli_node,
    message_format,
    positive_int,
    unsigned_int,
)
from rosbook.cli import values as given_values
from rosbook.cli.reporting import fail, reports_errors
from rosbook.runtime import graph
from rosbook.runtime.interfaces import InterfaceError, fill, message_class, to_csv, to_yaml


def hidden_topics(args: argparse.Namespace) -> bool:
    """``--include-hidden-topics``, given to the verb (``ros2 topic --include-hidden-topics
    list``) or to the command."""
    return bool(args.verb_include_hidden_topics or getattr(args, "include_hidden_topics", False))


def add_parser(verbs: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    parser = verbs.add_parser(
        "topic", help="Topics on the graph: list, info, echo, hz, pub, find, bw, type, delay"
    )
    parser.add_argument(
        "--include-hidden-topics",
        dest="verb_include_hidden_topics",
        action="store_true",
        help="Consider hidden topics as well",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = commands.add_parser("list", help="Output a list of available topics")
    add_strategy_arguments(p)
    p.add_argument("-t", "--show-types", action="store_true", help="Additionally show the type")
    p.add_argument(
        "-c", "--count-topics", action="store_true", help="Only display the number of topics"
    )
    p.add_argument(
        "--include-hidden-topics", action="store_true", help="Consider hidden topics as well"
    )
    p.add_argument(
        "-v", "--verbose", action="store_true", help="List full details about each topic"
    )
    p.set_defaults(func=list_topics)

    p = commands.add_parser("type", help="Print a topic's type")
    add_strategy_arguments(p)
    p.add_argument("topic_name", help="Name of the ROS topic to get type (e.g. '/chatter')")
    p.set_defaults(func=topic_type)

    p = commands.add_parser("info", help="Print information about a topic")
    add_strategy_arguments(p)
    p.add_argument("topic_name", help="Name of the ROS topic to get info (e.g. '/chatter')")
    p.add_argument(
        "-v", "--verbose", action="store_true", help="Print detailed information like QoS"
    )
    p.set_defaults(func=info)

    p = commands.add_parser("echo", help="Output messages from a topic")
    add_strategy_arguments(p)
    p.add_argument("topic_name", help="Name of the ROS topic to listen to (e.g. '/chatter')")
    p.add_argument(
        "message_type", nargs="?", help="Type of the ROS message (e.g. 'std_msgs/msg/String')"
    )
    add_qos_arguments(p, "subscribe", "sensor_data")
    p.add_argument(
        "--field",
        default=None,
        help="Echo a selected field of a message. Use '.' to select sub-fields.",
    )
    add_message_format_arguments(p)
    p.add_argument(
        "--no-lost-messages", action="store_true", help="Don't report when a message is lost"
    )
    p.add_argument("--raw", action="store_true", help="Echo the raw binary representation")
    p.add_argument(
        "--filter",
        dest="filter_expr",
        help="Python expression to filter messages that are printed. Expression can use "
        "Python builtins as well as m (the message).",
    )
    p.add_argument(
        "--once", action="store_true", help="Print the first message received and then exit."
    )
    p.add_argument(
        "--timeout",
        metavar="N",
        type=_positive_float,
        default=None,
        help="Set a timeout in seconds for waiting",
    )
    p.add_argument(
        "-i",
        "--include-message-info",
        action="store_true",
        help="Shows the associated message info.",
    )
    p.add_argument(
        "-n",
        "--max-count",
        type=positive_int,
        default=None,
        help=f"exit after N messages {ADDITION}",
    )
    p.set_defaults(func=echo)

    p = commands.add_parser("hz", help="Print the average publishing rate to screen")
    p.add_argument("topic_name", help="Name of the ROS topic to listen to (e.g. '/chatter')")
    p.add_argument(
        "-w",
        "--window",
        metavar="WINDOW",
        type=positive_int,
        default=10_000,
        help="window size, in # of messages, for calculating rate (default: 10000)",
    )
    p.add_argument(
        "--filter",
        dest="filter_expr",
        metavar="EXPR",
        default=None,
        help="only measure messages matching the specified Python expression",
    )
    p.add_argument(
        "--wall-time",
        dest="use_wtime",
        action="store_true",
        help="calculates rate using wall time which can be helpful when clock is not published "
        "during simulation",
    )
    add_direct_arguments(p)
    p.add_argument("--duration", type=float, default=None, help=f"stop after S seconds {ADDITION}")
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
    with cli_node(settle=True, args=args) as node:
        topics = graph.topic_names_and_types(node, include_hidden=hidden_topics(args))
        counts = [(node.count_publishers(n), node.count_subscribers(n)) for n, _ in topics]
    if args.count_topics:
        print(len(topics))
    elif topics and args.verbose:  # upstream's two blocks, each ending in a blank line
        for title, side, noun in (("Published", 0, "publisher"), ("Subscribed", 1, "subscriber")):
            print(f"{title} topics:")
            for (name, types), count in zip(topics, counts):
                if count[side]:
                    plural = "s" if count[side] > 1 else ""
                    print(f" * {name} [{', '.join(types)}] {count[side]} {noun}{plural}")
            print()
    else:
        for name, types in topics:
            print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return 0


@reports_errors
def topic_type(args: argparse.Namespace) -> int:
    """Each type of the topic, one a line; as upstream, nothing and exit 1 when the
    topic is unknown (the name is compared as given)."""
    with cli_node(args=args) as node:
        graph.lookup(lambda g: args.topic_name in dict(g.get_topic_names_and_types()), node)
        topics = dict(graph.topic_names_and_types(node, include_hidden=hidden_topics(args)))
    if args.topic_name not in topics:
        return 1
    print(*topics[args.topic_name], sep="\n")
    return 0


@reports_errors
def info(args: argparse.Namespace) -> int:
    topic = "/" + args.topic_name.lstrip("/")
    with cli_node(args=args) as node:
        if not graph.lookup(lambda g: topic in dict(g.get_topic_names_and_types()), node):
            return fail(f"Unknown topic '{topic}'")  # upstream's words
        graph.settle(node)  # every endpoint of it, each with its node's name
        text = graph.topic_info(topic, node).format(verbose=args.verbose)
    # upstream ends every line of -v with a blank one, the last one too
    print(text, end="\n\n" if args.verbose else "\n")
    return 0


def echo_qos(node: Node, topic: str, args: argparse.Namespace) -> QoSProfile:
    """The subscription's QoS as upstream's ``echo`` picks it: the ``--qos-*`` options on
    the preset when any is given, else the preset made reliable (transient-local) only
    if every publisher is, with upstream's notes when only some are."""
    if any(getattr(args, f"qos_{key}") is not None for key in QOS_OVERRIDES):
        return _qos(args)
    profile = _preset(args.qos_profile)
    publishers = node.get_publishers_info_by_topic(topic)
    if not publishers:
        return profile
    for policy, best, fallback in (
        ("reliability", QoSReliabilityPolicy.RELIABLE, QoSReliabilityPolicy.BEST_EFFORT),
        ("durability", QoSDurabilityPolicy.TRANSIENT_LOCAL, QoSDurabilityPolicy.VOLATILE),
    ):
        offering = sum(getattr(p.qos_profile, policy) == best for p in publishers)
        if 0 < offering < len(publishers):
            print(
                f"Some, but not all, publishers are offering {type(best).__name__}.{best.name}."
                f" Falling back to {type(fallback).__name__}.{fallback.name} as it will"
                " connect to all publishers"
            )
        setattr(profile, policy, best if offering == len(publishers) else fallback)
    return profile


def _filter(expression: str | None) -> Callable[[Any], bool] | None:
    """Upstream's ``--filter``: a Python expression of the message ``m``, the user's own
    code on their own machine, as upstream evaluates it."""
    if not expression:
        return None
    try:
        code = compile(expression, "<--filter>", "eval")
    except SyntaxError as error:
        raise InterfaceError(f"--filter {expression!r}: {error.msg}") from None

    def keep(m: Any) -> bool:
        try:
            return bool(eval(code, {}, {"m": m}))  # noqa: S307 - upstream's option
        except Exception as error:  # the user's expression: one line, not a traceback
            raise InterfaceError(
                f"--filter {expression!r}: {type(error).__name__}: {error}"
            ) from None

    return keep


def _field(message: Any, path: list[str], given: str) -> Any:
    """The ``--field`` ``a.b`` of ``message``; a one-line error naming it otherwise."""
    for part in path:
        try:
            message = getattr(message, part)
        except AttributeError as error:
            raise InterfaceError(f"Invalid field '{given}': {error}") from None
    return message


@reports_errors
def echo(args: argparse.Namespace) -> int:
    path = None
    if args.field is not None:
        path = [part for part in args.field.split(".") if part]
        if not path:
            return fail(f"Invalid field value '{args.field}'")
    keep = _filter(args.filter_expr)
    count = 1 if args.once else (args.max_count if args.max_count is not None else math.inf)
    timeout = math.inf if args.timeout is None else args.timeout
    options = message_format(args)
    printed = 0
    errors: list[InterfaceError] = []

    def show(msg: Any, msg_info: Any) -> None:
        nonlocal printed
        if printed >= count or errors:
            return
        try:
            shown = msg if path is None or args.raw else _field(msg, path, args.field)
            if keep is not None and not keep(shown):
                return
        except InterfaceError as error:
            errors.append(error)
            return
        printed += 1
        if not hasattr(shown, "SLOT_TYPES"):  # raw bytes or a primitive field: as is
            if args.include_message_info:
                print(
                    "---Got new message, message info:---",
                    msg_info,
                    "---Message data:---",
                    sep="\n",
                )
            print(shown, end="\n---\n", flush=True)
        elif args.csv:
            line = to_csv(shown, **options)
            if args.include_message_info:
                line = ",".join(str(v) for v in msg_info.values()) + "," + line
            print(line, flush=True)
        else:
            if args.include_message_info:
                print(yaml.dump(msg_info), end="---\n")
            print(
                to_yaml(shown, flow_style=args.flow_style, **options), "---", sep="\n", flush=True
            )

    def lost(status: Any) -> None:
        print(
            "A message was lost!!!\n\ttotal count change:"
            f"{status.total_count_change}\n\ttotal count: {status.total_count}",
            end="---\n",
            flush=True,
        )

    topic = "/" + args.topic_name.lstrip("/")
    with cli_node(args=args) as node:
        if args.message_type is not None:
            try:
                msg_type = message_class(args.message_type)
            except InterfaceError:
                return fail("The passed message type is invalid")
        else:
            if not find_publisher(node, args.topic_name):
                return fail("Could not determine the type for the passed topic")
            msg_type = message_class(graph.topic_info(topic, node).types[0])
        events = None if args.no_lost_messages else SubscriptionEventCallbacks(message_lost=lost)
        try:
            node.create_subscription(
                msg_type,
                topic,
                show,
                echo_qos(node, topic, args),
                event_callbacks=events,
                raw=args.raw,
            )
        except UnsupportedEventTypeError:  # an rmw without the event: as upstream, none
            node.create_subscription(
                msg_type, topic, show, echo_qos(node, topic, args), raw=args.raw
            )
        # --timeout ends the command quietly, as upstream; -n and --once when enough came
        graph.wait_for(lambda _: printed >= count or bool(errors), node, timeout=timeout)
    if errors:
        return fail(str(errors[0]))
    return 0


@reports_errors
def hz(args: argparse.Namespace) -> int:
    duration = math.inf if args.duration is None else args.duration
    with cli_node(args=args) as node:
        if not find_publisher(node, args.topic_name):
            return fail("Could not determine the type for the passed topic")
        monitor = graph.HzMonitor(
            args.topic_name,
            node,
            window=args.window,
            wall_time=args.use_wtime,
            keep=_filter(args.filter_expr),
        )
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


def add_publishing_parsers(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = commands.add_parser("pub", help="Publish a message to a topic")
    p.add_argument("topic_name", help="Name of the ROS topic to publish to (e.g. '/chatter')")
    p.add_argument("message_type", help="Type of the ROS message (e.g. 'std_msgs/msg/String')")
    add_values_argument(p, "values", "{}", "Values to fill the message with in YAML format")
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
        type=unsigned_int,
        default=0,
        help="Publish this number of times and then exit",
    )
    p.add_argument(
        "-w",
        "--wait-matching-subscriptions",
        type=unsigned_int,
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
    add_qos_arguments(p, "publish", "default")
    add_direct_arguments(p)
    p.set_defaults(func=pub)

    p = commands.add_parser("find", help="Output a list of available topics of a given type")
    add_strategy_arguments(p)
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
    add_direct_arguments(p)
    p.add_argument("--duration", type=float, default=None, help=f"stop after S seconds {ADDITION}")
    p.set_defaults(func=bw)

    p = commands.add_parser("delay", help="Display delay of topic from timestamp in header")
    p.add_argument("topic", help="Name of the ROS topic to listen to (e.g. '/chatter')")
    p.add_argument(
        "-w",
        "--window",
        type=positive_int,
        default=10_000,
        help="window size, in # of messages, for calculating rate, string to (default: 10000)",
    )
    add_direct_arguments(p)
    p.set_defaults(func=delay)


#: The ``--qos-*`` options that override a field of ``--qos-profile``.
QOS_OVERRIDES = (
    "depth",
    "history",
    "reliability",
    "durability",
    "liveliness",
    "liveliness_lease_duration_seconds",
)


def add_qos_arguments(parser: argparse.ArgumentParser, verb: str, default: str) -> None:
    """Upstream's ``--qos-*`` options, to ``verb`` ("publish", "subscribe") with."""
    parser.add_argument(
        "--qos-profile",
        choices=QoSPresetProfiles.short_keys(),
        default=default,
        help=f"Quality of service preset profile to {verb} with (default: {default})",
    )
    parser.add_argument(
        "--qos-depth",
        metavar="N",
        type=int,
        help=f"Queue size setting to {verb} with (overrides depth value of --qos-profile option)",
    )
    for policy, kind in (
        ("history", QoSHistoryPolicy),
        ("reliability", QoSReliabilityPolicy),
        ("durability", QoSDurabilityPolicy),
        ("liveliness", QoSLivelinessPolicy),
    ):
        parser.add_argument(
            f"--qos-{policy}",
            choices=kind.short_keys(),
            help=f"{policy} setting to {verb} with (overrides that of --qos-profile)",
        )
    parser.add_argument(
        "--qos-liveliness-lease-duration-seconds",
        type=float,
        help=f"liveliness lease duration setting to {verb} with (overrides that of --qos-profile)",
    )


def _preset(name: str) -> QoSProfile:
    """A copy of rclpy's preset profile ``name``: the preset itself is rclpy's global
    (``qos_profile_sensor_data`` is ``QoSPresetProfiles.SENSOR_DATA.value``), which a
    command run in this process must never change for the others."""
    return copy.copy(QoSPresetProfiles.get_from_short_key(name))


def _qos(args: argparse.Namespace) -> QoSProfile:
    """The preset ``--qos-profile`` with the ``--qos-*`` settings given on top (as upstream)."""
    profile = _preset(args.qos_profile)
    for policy, kind in (
        ("history", QoSHistoryPolicy),
        ("reliability", QoSReliabilityPolicy),
        ("durability", QoSDurabilityPolicy),
        ("liveliness", QoSLivelinessPolicy),
    ):
        if getattr(args, f"qos_{policy}"):
            setattr(profile, policy, kind.get_from_short_key(getattr(args, f"qos_{policy}")))
    if args.qos_depth is not None:
        profile.depth = args.qos_depth
    if args.qos_liveliness_lease_duration_seconds is not None:
        profile.liveliness_lease_duration = Duration(
            seconds=args.qos_liveliness_lease_duration_seconds
        )
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
        values = yaml.safe_load(given_values(args, "values"))
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

    with cli_node(name=args.node_name, args=args) as node:
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
    with cli_node(settle=True, args=args) as node:
        topics = graph.topic_names_and_types(node, include_hidden=hidden_topics(args))
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

    with cli_node(args=args) as node:
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


@reports_errors
def delay(args: argparse.Namespace) -> int:
    """Each second, the delay of the topic's messages from their ``header.stamp`` (by the
    node's clock: simulated with ``-s``), over the last ``--window``; as upstream."""
    topic = "/" + args.topic.lstrip("/")
    delays: deque[int] = deque(maxlen=args.window)
    last: list[int] = []  # the newest delay printed, to say "no new messages"
    errors: list[str] = []

    def record(msg: Any) -> None:
        if not hasattr(msg, "header"):
            errors.append("msg does not have header")
            return
        now = node.get_clock().now()
        if now.nanoseconds == 0:  # a simulated clock not started (or reset)
            if delays:
                print("time has reset, resetting counters", flush=True)
                delays.clear()
            return
        delays.append((now - RosTime.from_msg(msg.header.stamp)).nanoseconds)

    with cli_node(args=args) as node:
        if not find_publisher(node, topic):
            return fail("Could not determine the type for the passed topic")
        msg_type = message_class(graph.topic_info(topic, node).types[0])
        node.create_subscription(msg_type, topic, record, qos_profile_sensor_data)
        while not errors:
            graph.wait_for(lambda _: bool(errors), node, timeout=1.0)
            if not delays:
                continue
            newest = [len(delays), delays[-1]]
            if newest == last:
                print("no new messages", flush=True)
                continue
            last[:] = newest
            values = list(delays)
            mean = sum(values) / len(values)
            std_dev = math.sqrt(sum((v - mean) ** 2 for v in values) / len(values))
            print(
                f"average delay: {mean * 1e-9:.3f}\n\tmin: {min(values) * 1e-9:.3f}s "
                f"max: {max(values) * 1e-9:.3f}s std dev: {std_dev * 1e-9:.5f}s "
                f"window: {len(values)}",
                flush=True,
            )
    return fail(errors[0])
