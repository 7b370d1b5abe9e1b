"""A ``ros2``-style command line for the parts of the ROS 2 CLI this book uses.

There is no ``ros2`` CLI wheel, so the project provides the verbs the book and labs
need on top of rclpy, each with every option upstream's jazzy ``--help`` lists (and a
few of its own, marked ``ADDITION`` in their help). Each verb lives in its own module
``rosbook/cli/verb_<name>.py`` that defines ``add_parser(verbs)``: it registers
``ros2 <name> ...`` on the argparse sub-parsers ``verbs`` and sets ``func=handler``
with ``handler(args) -> int``. The command is installed as ``ros2`` in the project's
venv and also runs as ``python -m rosbook.cli``.

The read-only graph verbs (``rosbook.cli.daemon.ANSWERED``) ask a per-user graph daemon
when one runs (``ros2 daemon start|stop|status``; the first such command starts one
outside isolated runs): it has been discovering since it started, so it answers at once.
That path does not import rclpy; ``--no-daemon`` asks the graph directly.
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
from typing import TYPE_CHECKING

from rosbook.cli import daemon

if TYPE_CHECKING:
    from rclpy.node import Node

#: What marks an option this book's ``ros2`` adds to upstream's (in its ``--help``).
ADDITION = "(this book's addition: not in ros2)"
#: Longest string or sequence ``echo`` prints whole without ``--full-length`` (upstream's).
DEFAULT_TRUNCATE_LENGTH = 128

#: Longest a verb waits for an answer from what it found (a service's response, a
#: parameter service's answer), in seconds of wall time: a guard against a hang.
GRAPH_TIMEOUT_S = 20.0


def unsigned_int(text: str) -> int:
    """An argparse type: an integer, zero or more."""
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text} is not zero or more")
    return value


def positive_int(text: str) -> int:
    """An argparse type: an integer above zero."""
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{text} is not a positive number")
    return value


def add_message_format_arguments(parser: argparse.ArgumentParser) -> None:
    """How ``topic echo`` and ``service echo`` print a message (upstream's options):
    ``--csv``, ``-f/--full-length``, ``-l/--truncate-length``, ``--no-arr``,
    ``--no-str``, ``--flow-style``; ``message_format(args)`` reads them."""
    parser.add_argument(
        "--csv", action="store_true", help="Output all recursive fields separated by commas"
    )
    parser.add_argument(
        "-f",
        "--full-length",
        action="store_true",
        help="Output all elements for arrays, bytes and strings",
    )
    parser.add_argument(
        "-l",
        "--truncate-length",
        type=unsigned_int,
        default=DEFAULT_TRUNCATE_LENGTH,
        help="The length to truncate arrays, bytes, and string to "
        f"(default: {DEFAULT_TRUNCATE_LENGTH})",
    )
    parser.add_argument(
        "--no-arr", action="store_true", help="Don't print array fields of messages"
    )
    parser.add_argument(
        "--no-str", action="store_true", help="Don't print string fields of messages"
    )
    parser.add_argument("--flow-style", action="store_true", help="Print collections in flow style")


def message_format(args: argparse.Namespace) -> dict[str, object]:
    """The options of ``add_message_format_arguments`` as ``interfaces.to_plain`` takes them."""
    return {
        "truncate_length": None if args.full_length else args.truncate_length,
        "no_arr": args.no_arr,
        "no_str": args.no_str,
    }


def add_values_argument(
    parser: argparse.ArgumentParser, dest: str, default: str, help: str
) -> None:
    """A positional of YAML values (a message, a request, a goal), or upstream's
    ``--stdin`` to read them from standard input instead; ``values(args, dest)`` reads it."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument(dest, nargs="?", default=default, help=help)
    group.add_argument("--stdin", action="store_true", help="Read values from standard input")


def values(args: argparse.Namespace, dest: str) -> str:
    """The YAML of ``add_values_argument``'s positional ``dest``, or of stdin with ``--stdin``."""
    return sys.stdin.read() if args.stdin else str(getattr(args, dest))


def add_direct_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of a command whose node always runs in its own process (upstream's
    ``ros2cli.node.direct.add_arguments``): ``--spin-time`` and ``-s/--use-sim-time``."""
    parser.add_argument(
        "--spin-time",
        type=float,
        default=None,
        help="Spin time in seconds to wait for discovery (only applies when not using an "
        "already running daemon)",
    )
    parser.add_argument(
        "-s", "--use-sim-time", action="store_true", help="Enable ROS simulation time"
    )


def add_strategy_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of a command a daemon may answer (upstream's
    ``ros2cli.node.strategy.add_arguments``): the direct ones and ``--no-daemon``."""
    add_direct_arguments(parser)
    parser.add_argument(
        daemon.NO_DAEMON,
        action="store_true",
        help="Do not spawn nor use an already running daemon",
    )


@contextmanager
def private_node(name: str, *, use_sim_time: bool = False) -> Iterator[Node]:
    """A node named ``name`` in an rclpy context of its own (no signal handlers), its
    discovery start recorded for ``graph.settle``; shut down on exit. With
    ``use_sim_time`` its clock follows ``/clock``."""
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from rclpy.signals import SignalHandlerOptions

    from rosbook.runtime import graph

    started = time.monotonic()
    context = Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    overrides = [Parameter("use_sim_time", value=True)] if use_sim_time else []
    node = Node(
        name, context=context, start_parameter_services=False, parameter_overrides=overrides
    )
    graph.discovering_since(node, started)
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)


@contextmanager
def cli_node(
    *, settle: bool = False, name: str | None = None, args: argparse.Namespace | None = None
) -> Iterator[Node]:
    """A short-lived, hidden node in a context of its own.

    Started cold (no daemon), each verb waits for discovery: one that looks for a name
    uses ``graph.lookup`` (present as soon as seen, absent once the graph settled without
    it); with ``settle`` (listings of the whole graph) the node first waits until
    discovery has settled and at least one participant announcement period passed
    (``rosbook.runtime.graph.settle``). Its name starts with an underscore, like the real
    CLI's ``_ros2cli_*`` nodes, so graph listings leave it out by default; ``name`` names
    it otherwise (``topic pub -n``). In the daemon (``rosbook.cli.daemon``), it is the
    daemon's node, discovering for long. A command's ``args`` may carry upstream's
    ``--spin-time`` (discovery then lasts at least that long, as upstream's spin) and
    ``-s/--use-sim-time`` (``add_direct_arguments``).
    """
    from rosbook.runtime import graph

    if daemon.shared_node is not None:  # a request the daemon answers
        if settle:
            graph.settle(daemon.shared_node, at_least=graph.ANNOUNCE_PERIOD_S)
        yield daemon.shared_node
        return
    spin_time = getattr(args, "spin_time", None)
    sim_time = bool(getattr(args, "use_sim_time", False))
    with private_node(name or f"_ros2cli_{os.getpid()}", use_sim_time=sim_time) as node:
        if settle or spin_time is not None:
            at_least = max(graph.ANNOUNCE_PERIOD_S if settle else 0.0, spin_time or 0.0)
            graph.settle(node, at_least=at_least, timeout=max(graph.SETTLE_TIMEOUT_S, at_least))
        yield node


def build_parser(verb: str | None = None) -> argparse.ArgumentParser:
    """The command's parser: every verb, or only ``verb`` when it names one (a cold
    command then imports one verb's module, not all of them: it starts faster)."""
    parser = argparse.ArgumentParser(
        prog="ros2",
        description="The ros2 verbs this book uses, built on rclpy (see `ros2 VERB -h`).",
    )
    verbs = parser.add_subparsers(dest="verb", required=True, metavar="VERB")
    modules = sorted(m.name for m in pkgutil.iter_modules(__path__) if m.name.startswith("verb_"))
    if f"verb_{verb}" in modules:
        modules = [f"verb_{verb}"]
    for name in modules:
        importlib.import_module(f"{__name__}.{name}").add_parser(verbs)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    answered = daemon.ask(argv)
    if answered is not None:
        return answered
    argv = [a for a in argv if a != daemon.NO_DAEMON]  # direct anyway: accepted anywhere
    args = build_parser(argv[0] if argv else None).parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        return 0


if __name__ == "__main__":
    sys.exit(main())
