"""``ros2 bag record [-o DIR] [-s mcap|sqlite3] (TOPIC ... | -a)``, ``ros2 bag info DIR``,
``ros2 bag play DIR [-r RATE] [-l]``: rosbag2 folders, through :mod:`rosbook.runtime.bags`."""

from __future__ import annotations

import argparse
import functools
import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rclpy.duration import Duration
from rclpy.executors import TimeoutException
from rclpy.logging import get_logger

from rosbook.cli import cli_node
from rosbook.cli.reporting import fail, reports_errors
from rosbook.runtime import bags, graph
from rosbook.runtime.executors import SingleThreadedExecutor

#: How often ``record`` looks for new topics on the graph (upstream's polling interval).
POLL_S = 0.1
#: What ends a recording cleanly (the bag closed, its metadata written).
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def add_parser(verbs: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    parser = verbs.add_parser("bag", help="Record topics into bags, inspect and play them")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = commands.add_parser("record", help="Record topics into a bag until Ctrl-C")
    p.add_argument("topics", nargs="*", metavar="Topic", help="topics to record")
    p.add_argument(
        "--topics",
        dest="topics_option",
        nargs="+",
        default=[],
        metavar="Topic",
        help="topics to record",
    )
    p.add_argument(
        "-a", "--all", action="store_true", help="record all topics (except hidden ones)"
    )
    p.add_argument(
        "-o",
        "--output",
        help="destination folder of the bag, defaults to a timestamped folder here",
    )
    p.add_argument(
        "-s",
        "--storage",
        default=bags.DEFAULT_STORAGE,
        choices=list(bags.STORAGES),
        help="storage identifier, defaults to '%(default)s'",
    )
    p.set_defaults(func=record)

    p = commands.add_parser("info", help="Print a bag's files, duration and topics")
    p.add_argument("bag_path")
    p.set_defaults(func=info)

    p = commands.add_parser("play", help="Publish a bag's messages at their recorded timing")
    p.add_argument("bag_path")
    p.add_argument(
        "-r", "--rate", type=_positive, default=1.0, help="play RATE times as fast as recorded"
    )
    p.add_argument("-l", "--loop", action="store_true", help="start over at the end, forever")
    p.add_argument("--topics", nargs="+", default=None, metavar="Topic", help="only these")
    p.set_defaults(func=play)


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"Value {text} is less than or equal to zero.")
    return value


def reports_bag_errors(handler: Callable[[argparse.Namespace], int]) -> Callable[..., int]:
    @functools.wraps(handler)
    def wrapped(args: argparse.Namespace) -> int:
        try:
            return handler(args)
        except bags.BagError as error:
            return fail(f"[ERROR] [ros2bag]: {error}")

    return reports_errors(wrapped)


@reports_bag_errors
def record(args: argparse.Namespace) -> int:
    topics = list(args.topics) + list(args.topics_option)
    if not args.all and not topics:
        return fail(
            "[ERROR] [ros2bag]: Need to specify at least one option out of --all, "
            "--all-topics, --all-services, --services, --topics, --topic-types or --regex"
        )
    path = args.output or bags.default_path()
    log = get_logger("rosbag2_recorder")
    with _stopped_by_signals() as stop, cli_node() as node:
        recorder = bags.Recorder(
            node,
            path,
            None if args.all else topics,
            args.storage,
            on_subscribed=lambda t: log.info(f"Subscribed to topic '{t}'"),
            on_unknown_type=log.warning,
        )
        executor = SingleThreadedExecutor(context=node.context)
        executor.add_node(node)
        try:
            log.info("Listening for topics...")
            recorder.discover()
            log.info("Recording...")
            while not stop.is_set():
                executor.spin_once(timeout_sec=POLL_S)
                recorder.discover()
            # what arrived before Ctrl-C is still queued: store it
            for _ in range(bags.RECORD_DEPTH * len(recorder.topics)):
                if not _run_ready(executor):
                    break
        finally:
            executor.remove_node(node)
            executor.shutdown(timeout_sec=0)
            recorder.close()  # writes metadata.yaml
            log.info("Recording stopped")
    return 0


@contextmanager
def _stopped_by_signals() -> Iterator[threading.Event]:
    """An event that Ctrl-C (SIGINT) or SIGTERM sets, instead of interrupting whatever
    runs (a message half written to the bag)."""
    stop = threading.Event()
    previous = {sig: signal.signal(sig, lambda *_: stop.set()) for sig in STOP_SIGNALS}
    try:
        yield stop
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _run_ready(executor: SingleThreadedExecutor) -> bool:
    """Run one callback that is ready now; False when none is."""
    try:
        handler, *_ = executor.wait_for_ready_callbacks(timeout_sec=0)
    except TimeoutException:
        return False
    handler()
    return True


@reports_bag_errors
def info(args: argparse.Namespace) -> int:
    print(bags.info(args.bag_path).format())
    return 0


@reports_bag_errors
def play(args: argparse.Namespace) -> int:
    with cli_node() as node:
        player = bags.Player(
            node, args.bag_path, rate=args.rate, loop=args.loop, topics=args.topics
        )
        player.wait_for_subscribers()
        try:
            player.play()
        except KeyboardInterrupt:
            pass
        finally:
            # the last messages reach a reliable subscriber before the publishers go
            for publisher in player.publishers.values():
                publisher.wait_for_all_acked(Duration(seconds=graph.SETTLE_TIMEOUT_S))
            player.close()
    return 0
