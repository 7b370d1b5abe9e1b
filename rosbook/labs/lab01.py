"""Lab 1's checks (nodes and topics): what the lab's test cells call as ``checks``.

Lab 1's own assertions live here; the probes every lab shares (a probe node, endpoint
checks, running a script and stopping it with Ctrl-C) live in :mod:`rosbook.labs.probes`
and are importable from here too, so a test cell needs only ``checks``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile

from rosbook.labs.deferral import deferrable
from rosbook.labs.lockstep import published_on_sim_time
from rosbook.labs.probes import *  # noqa: F403 (the shared probes, as checks.X)
from rosbook.labs.probes import (
    CheckFailed,
    Probe,
    Received,
    ScriptRun,
    Sender,
    TimedOut,
    _short,
    assert_sequence,
    assert_still_running,
    node_publishes,
    wait_for_script_publisher,
)
from rosbook.labs.remote import (
    EVENT_GUARD_S,
    clock_message,
    clock_publisher,
    is_student,
    judgement,
)
from rosbook.runtime.graph import absolute_name
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
    """Run ``node`` for ``seconds`` of simulated time and return what ``topic`` carried
    (when graded: the node in the student's kernel, in lockstep with the judge's clock)."""
    node_publishes(node, topic, msg_type)
    if is_student(node):
        j = judgement()
        name = node.get_name()
        j.wait_on_graph(name, absolute_name(topic), "publisher")
        data, times = published_on_sim_time(
            j, name, absolute_name(topic), msg_type, seconds, step=max(step, 0.1)
        )
        return Received([msg_type(data=d) for d in data], times)
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
    timeout: float = EVENT_GUARD_S,
) -> None:
    """Publish ``values`` on ``topic`` one at a time, each once the last was handled
    (``received()`` grew), and compare ``received()`` with ``expected``.

    A result that does not come within ``timeout`` (a guard) is not yet wrong: the next
    value goes out, and if a later one is handled the missing one was skipped (wrong).
    When the node falls silent (two misses in a row, or the last) with every result so
    far right, that is a timeout (a starved machine or a stalled node), never wrong."""
    sender = Sender(topic, msg_type)
    try:
        sender.wait_for_subscriber()
        got = list(received())
        misses = 0
        for value in values:
            before = len(got)
            sender.send([value])
            ros.spin_until(lambda before=before: len(received()) > before, timeout=timeout)
            got = list(received())
            misses = misses + 1 if len(got) <= before else 0
            if misses == 2:
                break
        if misses and len(got) < len(expected) and got == list(expected[: len(got)]):
            ros.spin_until(lambda: len(received()) >= len(expected), timeout=timeout)
            got = list(received())
            if len(got) < len(expected) and got == list(expected[: len(got)]):
                raise TimedOut(
                    f"handled {len(got)} of the {len(values)} values sent on {sender.topic} "
                    f"({_short(values)}), each waited for {timeout:.0f} s: all it handled "
                    "was right, then it fell silent"
                )
        ros.spin_for(0.05)  # a surplus message would arrive now
        assert_sequence(
            f"after publishing {_short(values)} on {sender.topic}", list(received()), expected
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
    """Drive a script started with ``use_sim_time:=true`` through ``seconds`` of /clock,
    and return what ``probe`` received.

    Another process's clock cannot be read from here; what paces the steps is what
    arrives: at each multiple of ``expect_every`` (the talker's period) one more message
    is waited for (a right talker is waited for at each; a wrong one once), with the
    time published again meanwhile (a /clock message sent before the script's
    subscription met this publisher is lost)."""
    wait_for_script_publisher(run, probe)
    _wait_until_heard(probe)
    publisher = clock_publisher(probe.node)
    if not ros.spin_until(
        lambda: publisher.get_subscription_count() > 0 or not run.alive(), probe.node, timeout=10.0
    ):
        raise CheckFailed(
            f"{run.path.name} does not listen to /clock when started with "
            "--ros-args -p use_sim_time:=true: does main() pass its args to "
            "rclpy.init(args=args)?"
        )
    assert_still_running(run)
    waiting = True
    steps = int(round(seconds / step))
    per_message = int(round(TALKER_PERIOD_S / step))
    for k in range(1, steps + 1):
        t = step * k
        publisher.publish(clock_message(t))
        if waiting and k % per_message == 0:
            waiting = _republishing(
                publisher, t, lambda k=k: len(probe.received.messages) >= k // per_message, probe
            )
        else:
            ros.spin_for(0.0, probe.node)
    ros.spin_for(0.2, probe.node)
    return probe.received


#: The talker's period (2 Hz): a right talker sends one message each.
TALKER_PERIOD_S = 0.5


def _wait_until_heard(probe: Probe) -> None:
    """Wait until the script's publisher on the probe's topic has found the probe.

    Matching runs on each side on its own, and what the script sends before is lost
    (its first message, at 0.5 s of simulated time, is never sent again). Its side
    cannot be asked, but its node answers its parameter services: a reply can only come
    once it has taken in this service client, announced after the subscription."""
    from rcl_interfaces.srv import ListParameters

    node = probe.node
    named = lambda: [  # noqa: E731
        i for i in node.get_publishers_info_by_topic(probe.topic) if not i.node_name.startswith("_")
    ]
    if not ros.spin_until(lambda: bool(named()), node, timeout=10.0):
        return
    talker = named()[0]
    service = f"{talker.node_namespace.rstrip('/')}/{talker.node_name}/list_parameters"
    client = node.create_client(ListParameters, service)
    try:
        if ros.spin_until(client.service_is_ready, node, timeout=10.0):
            reply = client.call_async(ListParameters.Request())
            ros.spin_until(reply.done, node, timeout=10.0)
    finally:
        node.destroy_client(client)


def _republishing(publisher: Any, t: float, condition: Callable[[], bool], probe: Probe) -> bool:
    """Spin until ``condition``, publishing /clock at ``t`` again every 0.2 s meanwhile
    (the same time again moves nothing); whether it came within a guard of 10 s."""
    deadline = time.monotonic() + 10.0
    while not ros.spin_until(condition, probe.node, timeout=0.2):
        if time.monotonic() > deadline:
            return False
        publisher.publish(clock_message(t))
    return True


deferrable(globals())
