"""Lab 1's checks (nodes and topics): what the lab's test cells call as ``checks``.

Lab 1's own assertions live here; the probes every lab shares (a probe node, endpoint
checks, running a script and stopping it with Ctrl-C) live in :mod:`rosbook.labs.probes`
and are importable from here too, so a test cell needs only ``checks``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile

from rosbook.labs.deferral import deferrable
from rosbook.labs.probes import *  # noqa: F403 (the shared probes, as checks.X)
from rosbook.labs.probes import (
    CheckFailed,
    Probe,
    Received,
    ScriptRun,
    Sender,
    _short,
    assert_sequence,
    node_publishes,
    wait_for_script_publisher,
)
from rosbook.runtime.session import SimClock, ros


class RosoutLog:
    """The log lines nodes send to ``/rosout`` (what ``ros2 topic echo /rosout`` shows).

    Transient local, as every node's ``/rosout`` publisher is (rcl keeps its last 1000
    lines for 10 s): a line logged before the node's publisher discovered this
    subscription comes late, not never (on a busy machine discovery can take seconds)."""

    def __init__(self) -> None:
        self.node = Node("rosout_listener")
        self.lines: list[Log] = []
        kept = QoSProfile(depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.node.create_subscription(Log, "/rosout", self.lines.append, kept)

    def of(self, node_name: str) -> list[str]:
        return [line.msg for line in self.lines if line.name == node_name]

    def close(self) -> None:
        ros.remove(self.node)


def expect_published(
    node: Node,
    topic: str,
    msg_type: type,
    clock: SimClock,
    seconds: float,
    step: float = 0.01,
) -> Received:
    """Run ``node`` for ``seconds`` of simulated time and return what ``topic`` carried."""
    node_publishes(node, topic, msg_type)
    probe = Probe(topic, msg_type)
    try:
        probe.wait_for_publisher()
        clock.advance(seconds, step=step)
        ros.spin_for(0.05)  # deliveries still on the wire
        return probe.received
    finally:
        probe.close()


def assert_relayed(
    topic: str,
    msg_type: type,
    values: Sequence[Any],
    received: Callable[[], Sequence[Any]],
    expected: Sequence[Any],
    timeout: float = 20.0,
) -> None:
    """Publish ``values`` on ``topic`` and compare ``received()`` with ``expected``
    (``timeout``: a guard; it returns as soon as enough arrived)."""
    sender = Sender(topic, msg_type)
    try:
        sender.wait_for_subscriber()
        sender.send(values)
        ros.spin_until(lambda: len(received()) >= len(expected), timeout=timeout)
        ros.spin_for(0.05)  # a surplus message would arrive now
        assert_sequence(
            f"after publishing {_short(values)} on {sender.topic}", received(), expected
        )
    finally:
        sender.close()


def assert_times(
    name: str, got: Sequence[float], expected: Sequence[float], tol: float = 0.011
) -> None:
    """Arrival times (simulated seconds) must match ``expected`` within ``tol``."""
    bad = [(i, g, e) for i, (g, e) in enumerate(zip(got, expected)) if abs(g - e) > tol]
    if bad or len(got) != len(expected):
        shown = ", ".join(f"{t:.2f}" for t in got)
        raise CheckFailed(
            f"{name}: messages arrived at t = [{shown}] s (simulated), expected one every "
            f"{expected[0]:.2f} s. Is the timer created with the `period` argument?"
        )


#: Longest ``assert_logged`` waits for log lines to arrive on /rosout (a guard).
LOG_WAIT_S = 5.0


def assert_logged(log: RosoutLog, node_name: str, fragments: Sequence[str]) -> None:
    """Each fragment must appear in a log line of ``node_name`` (its logger, not print);
    waits for them up to ``LOG_WAIT_S`` (they may still be on their way on a busy machine)."""

    def not_logged() -> list[str]:
        return [f for f in fragments if not any(f in line for line in log.of(node_name))]

    ros.spin_until(lambda: not not_logged(), timeout=LOG_WAIT_S)
    lines = log.of(node_name)
    missing = not_logged()
    if missing:
        raise CheckFailed(
            f"node '{node_name}' logged {len(lines)} line(s) to /rosout, and none mentions "
            f"{_short(missing)}. Log each value with self.get_logger().info(...); "
            "print() output does not reach /rosout."
        )


HELLO_PREFIX = "Hello World: "


def assert_hello_world(data: Sequence[str], at_least: int) -> None:
    """Messages are 'Hello World: N' with N counting up by one."""
    if len(data) < at_least:
        raise CheckFailed(
            f"received {len(data)} message(s) on /chatter, expected at least {at_least}: "
            "is the timer publishing twice a second?"
        )
    numbers = []
    for text in data:
        if not text.startswith(HELLO_PREFIX) or not text[len(HELLO_PREFIX) :].isdigit():
            raise CheckFailed(
                f"received {text!r} on /chatter; each message must read 'Hello World: N'"
            )
        numbers.append(int(text[len(HELLO_PREFIX) :]))
    if any(b != a + 1 for a, b in zip(numbers, numbers[1:])):
        raise CheckFailed(f"the counter in the messages must go up by one: {numbers}")


def sim_time_messages(
    run: ScriptRun, probe: Probe, clock: SimClock, seconds: float, step: float = 0.05
) -> Received:
    """Drive a script started with ``use_sim_time:=true`` through ``seconds`` of /clock.

    Another process's clock cannot be read from here, so each step is published and
    then given a short settle time in which the script reacts and its messages arrive.
    """
    wait_for_script_publisher(run, probe)
    local = len(ros.nodes)  # every node of a sim-time session listens to /clock
    if not ros.spin_until(lambda: clock.subscriber_count() > local, timeout=5.0):
        raise CheckFailed(
            f"{run.path.name} does not listen to /clock when started with "
            "--ros-args -p use_sim_time:=true: does main() pass its args to "
            "rclpy.init(args=args)?"
        )
    clock.advance_remote(seconds, step=step, settle=0.02)
    ros.spin_for(0.2, probe.node)
    return probe.received


deferrable(globals())
