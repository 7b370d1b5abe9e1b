"""Every option upstream's ``ros2`` offers for the verbs this project ships is accepted here.

The table below is a fact about upstream, read from ros2/ros2cli's jazzy branch: each
command's ``add_arguments`` in ``ros2<verb>/ros2<verb>/verb/<command>.py``, the verb's
own in ``ros2<verb>/ros2<verb>/command/<verb>.py``, and the shared helpers they call
(``ros2cli/node/strategy.py``, ``ros2cli/node/direct.py``, ``ros2topic/api``'s
``add_qos_arguments``). CI has no network, so it is written out here. Each entry lists a
command's positionals by name, in order, and its options by their flags.
"""

from __future__ import annotations

import argparse

import pytest

from rosbook.cli import build_parser

#: ``ros2cli.node.direct.add_arguments``.
DIRECT = ("--spin-time", "-s --use-sim-time")
#: ``ros2cli.node.strategy.add_arguments`` (the daemon's adds nothing).
STRATEGY = (*DIRECT, "--no-daemon")
#: ``ros2topic.api.add_qos_arguments``.
QOS = (
    "--qos-profile",
    "--qos-depth",
    "--qos-history",
    "--qos-reliability",
    "--qos-durability",
    "--qos-liveliness",
    "--qos-liveliness-lease-duration-seconds",
)
#: Options of a parameter verb besides ``STRATEGY``.
PARAM_NODE = ("--include-hidden-nodes", "--timeout")

#: Options of the verb itself, before its command (``ros2 topic --include-hidden-topics``).
VERB_OPTIONS = {
    "topic": ("--include-hidden-topics",),
    "service": ("--include-hidden-services",),
    "action": (),
    "param": (),
    "interface": (),
    "pkg": (),
}

#: (verb, command): (positionals, options), as upstream's jazzy ``add_arguments`` has them.
UPSTREAM: dict[tuple[str, str], tuple[tuple[str, ...], tuple[str, ...]]] = {
    ("topic", "bw"): (("topic",), ("-w --window", *DIRECT)),
    ("topic", "delay"): (("topic",), ("-w --window", *DIRECT)),
    ("topic", "echo"): (
        ("topic_name", "message_type"),
        (
            *STRATEGY,
            *QOS,
            "--csv",
            "--field",
            "-f --full-length",
            "-l --truncate-length",
            "--no-arr",
            "--no-str",
            "--flow-style",
            "--no-lost-messages",
            "--raw",
            "--filter",
            "--once",
            "--timeout",
            "-i --include-message-info",
        ),
    ),
    ("topic", "find"): (
        ("topic_type",),
        (*STRATEGY, "-c --count-topics", "--include-hidden-topics"),
    ),
    ("topic", "hz"): (("topic_name",), ("-w --window", "--filter", "--wall-time", *DIRECT)),
    ("topic", "info"): (("topic_name",), (*STRATEGY, "-v --verbose")),
    ("topic", "list"): (
        (),
        (
            *STRATEGY,
            "-t --show-types",
            "-c --count-topics",
            "--include-hidden-topics",
            "-v --verbose",
        ),
    ),
    ("topic", "pub"): (
        ("topic_name", "message_type", "values"),
        (
            "--stdin",
            "-r --rate",
            "-p --print",
            "-1 --once",
            "-t --times",
            "-w --wait-matching-subscriptions",
            "--max-wait-time-secs",
            "--keep-alive",
            "-n --node-name",
            *QOS,
            *DIRECT,
        ),
    ),
    ("topic", "type"): (("topic_name",), STRATEGY),
    ("service", "call"): (
        ("service_name", "service_type", "values"),
        ("--stdin", "-r --rate"),
    ),
    ("service", "echo"): (
        ("service_name", "service_type"),
        (
            "--csv",
            "-f --full-length",
            "-l --truncate-length",
            "--no-arr",
            "--no-str",
            "--flow-style",
        ),
    ),
    ("service", "find"): (
        ("service_type",),
        ("-c --count-services", "--include-hidden-services"),
    ),
    ("service", "info"): (("service_name",), STRATEGY),
    ("service", "list"): (
        (),
        (*STRATEGY, "-t --show-types", "-c --count-services", "--include-hidden-services"),
    ),
    ("service", "type"): (("service_name",), ()),
    ("action", "info"): (("action_name",), ("-t --show-types", "-c --count")),
    ("action", "list"): ((), ("-t --show-types", "-c --count-actions")),
    ("action", "send_goal"): (
        ("action_name", "action_type", "goal"),
        ("--stdin", "-f --feedback"),
    ),
    ("action", "type"): (("action_name",), ()),
    ("param", "delete"): (("node_name", "parameter_name"), (*STRATEGY, *PARAM_NODE)),
    ("param", "describe"): (("node_name", "parameter_names"), (*STRATEGY, *PARAM_NODE)),
    ("param", "dump"): (("node_name",), (*STRATEGY, *PARAM_NODE)),
    ("param", "get"): (
        ("node_name", "parameter_name"),
        (*STRATEGY, *PARAM_NODE, "--hide-type"),
    ),
    ("param", "list"): (
        ("node_name",),
        (*STRATEGY, "--filter", "--include-hidden-nodes", "--param-prefixes", "--param-type"),
    ),
    ("param", "load"): (
        ("node_name", "parameter_file"),
        (*STRATEGY, *PARAM_NODE, "--no-use-wildcard"),
    ),
    ("param", "set"): (("node_name", "parameter_name", "value"), (*STRATEGY, *PARAM_NODE)),
    ("interface", "list"): ((), ("-m --only-msgs", "-s --only-srvs", "-a --only-actions")),
    ("interface", "package"): (
        ("package_name",),
        ("-m --only-msgs", "-s --only-srvs", "-a --only-actions"),
    ),
    ("interface", "packages"): ((), ("-m --only-msgs", "-s --only-srvs", "-a --only-actions")),
    ("interface", "proto"): (("type",), ("--no-quotes",)),
    ("interface", "show"): (("type",), ("--all-comments", "--no-comments")),
    ("pkg", "create"): (
        ("package_name",),
        (
            "--package-format --package_format",
            "--description",
            "--license",
            "--destination-directory",
            "--build-type",
            "--dependencies",
            "--maintainer-email",
            "--maintainer-name",
            "--node-name",
            "--library-name",
        ),
    ),
    ("pkg", "executables"): (("package_name",), ("--full-path",)),
    ("pkg", "list"): ((), ()),
    ("pkg", "prefix"): (("package_name",), ("--share",)),
    ("pkg", "xml"): (("package_name",), ("-t --tag",)),
}


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _options(parser: argparse.ArgumentParser) -> set[frozenset[str]]:
    return {
        frozenset(a.option_strings)
        for a in parser._actions
        if a.option_strings and not isinstance(a, argparse._HelpAction)
    }


def _positionals(parser: argparse.ArgumentParser) -> list[str]:
    return [
        a.dest
        for a in parser._actions
        if not a.option_strings and not isinstance(a, argparse._SubParsersAction)
    ]


VERBS = _subparsers(build_parser())


@pytest.mark.parametrize("verb", sorted(VERB_OPTIONS))
def test_each_upstream_command_of_a_shipped_verb_exists(verb: str) -> None:
    upstream = {command for v, command in UPSTREAM if v == verb}
    assert upstream <= set(_subparsers(VERBS[verb])), upstream - set(_subparsers(VERBS[verb]))


@pytest.mark.parametrize("verb", sorted(VERB_OPTIONS))
def test_verb_level_options_are_upstreams(verb: str) -> None:
    ours = _options(VERBS[verb])
    missing = [o for o in VERB_OPTIONS[verb] if frozenset(o.split()) not in ours]
    assert not missing, f"ros2 {verb}: missing {missing}"


@pytest.mark.parametrize("verb_command", sorted(UPSTREAM), ids=" ".join)
def test_every_upstream_option_is_accepted_with_the_same_flags(
    verb_command: tuple[str, str],
) -> None:
    verb, command = verb_command
    parser = _subparsers(VERBS[verb])[command]
    positionals, options = UPSTREAM[verb_command]
    ours = _options(parser)
    missing = [o for o in options if frozenset(o.split()) not in ours]
    assert not missing, f"ros2 {verb} {command}: missing or spelled otherwise: {missing}"
    assert _positionals(parser) == list(positionals), f"ros2 {verb} {command}: positionals"
