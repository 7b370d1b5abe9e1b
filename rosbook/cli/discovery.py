"""Waiting for discovery in a fresh CLI node: for what a command needs, not a fixed time.

The real CLI keeps a daemon that has seen the graph for long; a CLI node of this
project starts cold, and Fast DDS sometimes takes two or three seconds to meet the
participants already running. Each command waits until what it looks for is known,
bounded by ``GRAPH_TIMEOUT_S``.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from rclpy.node import Node

#: Longest wait for the graph to show what a command needs (seconds of wall time).
GRAPH_TIMEOUT_S = 5.0
#: How long the graph must stay unchanged before a listing trusts it (seconds).
SETTLE_S = 0.5


def wait_for(condition: Callable[[], bool], timeout: float = GRAPH_TIMEOUT_S) -> bool:
    """Poll ``condition`` (a graph query) until it holds or ``timeout`` passes."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def other_nodes(node: Node) -> list[tuple[str, str]]:
    """The (name, namespace) of every node in the graph but the CLI's own (hidden) ones."""
    return [(n, ns) for n, ns in node.get_node_names_and_namespaces() if not n.startswith("_")]


def graph_snapshot(node: Node) -> tuple:
    """What the graph shows now: nodes, topics and services with their types."""
    return (
        sorted(other_nodes(node)),
        sorted((name, tuple(types)) for name, types in node.get_topic_names_and_types()),
        sorted((name, tuple(types)) for name, types in node.get_service_names_and_types()),
    )


def settle(node: Node, timeout: float = GRAPH_TIMEOUT_S) -> None:
    """Wait until some other node is known and the graph stopped changing for a while.

    Node names and their endpoints are announced separately, so the first node seen
    does not mean its services and topics are known yet.
    """
    deadline = time.monotonic() + timeout
    if not wait_for(lambda: bool(other_nodes(node)), timeout):
        return
    last, since = graph_snapshot(node), time.monotonic()
    while time.monotonic() - since < SETTLE_S and time.monotonic() < deadline:
        time.sleep(0.05)
        now = graph_snapshot(node)
        if now != last:
            last, since = now, time.monotonic()
