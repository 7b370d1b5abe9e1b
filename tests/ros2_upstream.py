"""Upstream's ``ros2`` options, as a fact: the positionals and option flags of each
command of the verbs this book's ``ros2`` stands in for.

Read from the jazzy branches of ros2/ros2cli (each command's ``add_arguments`` in
``ros2<verb>/ros2<verb>/verb/<command>.py``, the verb's own in
``ros2<verb>/ros2<verb>/command/<verb>.py``, the shared helpers in
``ros2cli/node/strategy.py``, ``ros2cli/node/direct.py`` and ``ros2topic/api``'s
``add_qos_arguments``), of ros2/rosbag2 (``ros2bag/ros2bag/verb/*.py`` and
``ros2bag/api``) and of ros2/launch_ros (``ros2launch/ros2launch/command/launch.py``).
CI has no network, so the lists are written out here; ``tests/test_cli_options.py``
proves ``ros2`` accepts them, ``tests/test_book_ros2_options.py`` that the book uses
nothing else unless it says so.
"""

from __future__ import annotations

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
    "lifecycle": (),
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
    ("lifecycle", "get"): (("node_name",), (*STRATEGY, "--include-hidden-nodes")),
    ("lifecycle", "list"): (("node_name",), (*STRATEGY, "--include-hidden-nodes", "-a --all")),
    ("lifecycle", "nodes"): ((), (*STRATEGY, "-a --all", "-c --count-nodes")),
    ("lifecycle", "set"): (("node_name", "transition"), (*STRATEGY, "--include-hidden-nodes")),
}

#: Verbs the book uses whose every option ``ros2`` need not have (it says which it
#: leaves out), by (verb, command or ""): (positionals, options).
OTHER_VERBS: dict[tuple[str, str], tuple[tuple[str, ...], tuple[str, ...]]] = {
    ("node", "list"): ((), (*STRATEGY, "-a --all", "-c --count-nodes")),
    ("node", "info"): (("node_name",), (*STRATEGY, "--include-hidden")),
    ("daemon", "start"): ((), ("-d --debug",)),
    ("daemon", "status"): ((), ()),
    ("daemon", "stop"): ((), ()),
    ("doctor", ""): (
        (),
        ("-r --report", "-rf --report-failed", "-ep --exclude-packages", "-iw --include-warnings"),
    ),
    ("doctor", "hello"): (
        (),
        ("-t --topic", "-ep --emit-period", "-pp --print-period", "--ttl", "-1 --once"),
    ),
    ("run", ""): (("package_name", "executable_name", "argv"), ("--prefix",)),
    ("launch", ""): (
        ("package_name", "launch_file_name", "launch_arguments"),
        (
            "-n --noninteractive",
            "-d --debug",
            "-p --print --print-description",
            "-s --show-args --show-arguments",
            "-a --show-all-subprocesses-output",
            "--launch-prefix",
            "--launch-prefix-filter",
        ),
    ),
    ("bag", "info"): (("bag_path",), ("-t --topic-name", "-v --verbose", "-s --storage")),
    ("bag", "play"): (
        ("bag_path",),
        (
            "-s --storage",
            "--read-ahead-queue-size",
            "-r --rate",
            "--topics",
            "--services",
            "-e --regex",
            "-x --exclude-regex",
            "--exclude-topics",
            "--exclude-services",
            "--qos-profile-overrides-path",
            "-l --loop",
            "--remap -m",
            "--storage-config-file",
            "--clock",
            "--clock-topics",
            "--clock-topics-all",
            "-d --delay",
            "--playback-duration",
            "--playback-until-sec",
            "--playback-until-nsec",
            "--disable-keyboard-controls",
            "-p --start-paused",
            "--start-offset",
            "--wait-for-all-acked",
            "--disable-loan-message",
            "--publish-service-requests",
            "--service-requests-source",
            "--log-level",
        ),
    ),
    ("bag", "record"): (
        ("topics_positional",),
        (
            "-o --output",
            "-s --storage",
            "--topics",
            "--services",
            "--topic-types",
            "-a --all",
            "--all-topics",
            "--all-services",
            "-e --regex",
            "--exclude-regex",
            "--exclude-topic-types",
            "--exclude-topics",
            "--exclude-services",
            "--include-unpublished-topics",
            "--include-hidden-topics",
            "--no-discovery",
            "-p --polling-interval",
            "--ignore-leaf-topics",
            "--qos-profile-overrides-path",
            "-f --serialization-format",
            "-b --max-bag-size",
            "-d --max-bag-duration",
            "--max-cache-size",
            "--disable-keyboard-controls",
            "--start-paused",
            "--use-sim-time",
            "--node-name",
            "--custom-data",
            "--snapshot-mode",
            "--log-level",
            "--compression-queue-size",
            "--compression-threads",
            "--compression-threads-priority",
            "--compression-mode",
            "--compression-format",
            "--storage-config-file",
            "--storage-preset-profile",
        ),
    ),
}


def upstream_flags(verb: str, command: str) -> set[str] | None:
    """Every flag upstream's ``ros2 VERB [COMMAND]`` accepts (the verb's own too); None
    when upstream has no such verb or command."""
    entry = UPSTREAM.get((verb, command)) or OTHER_VERBS.get((verb, command))
    if entry is None:
        return None
    options = (*entry[1], *VERB_OPTIONS.get(verb, ()))
    return {flag for option in options for flag in option.split()}
