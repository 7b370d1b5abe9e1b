"""Checks that lab test cells run against a student's real nodes.

Every failure is an ``AssertionError`` whose message says what was expected, what was
seen and the likely ROS cause (topic name, message type, not publishing, not exiting
cleanly), so a student's feedback names the mistake without showing hidden test code.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import traceback
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.qos import QoSProfile

from rosbook.session import SimClock, ros

T = TypeVar("T")

#: Wall-clock bound for discovery between two endpoints in one process.
MATCH_TIMEOUT_S = 2.0


def make_node(factory: Callable[..., T], *args: Any, **kwargs: Any) -> T:
    """Build the student's node, turning a crash into a message that says where."""
    call = f"{getattr(factory, '__name__', factory)}({_call_args(args, kwargs)})"
    try:
        return factory(*args, **kwargs)
    except NotImplementedError:
        raise AssertionError(f"{call}: this task is not done yet (NotImplementedError)") from None
    except Exception as exc:  # the student's constructor failed: say how
        raise AssertionError(f"{call} raised {type(exc).__name__}: {exc} ({_where(exc)})") from None


def type_name(msg_type: type) -> str:
    """``std_msgs/msg/Int64`` for ``std_msgs.msg.Int64``."""
    package = msg_type.__module__.split(".")[0]
    return f"{package}/msg/{msg_type.__name__}"


def node_publishes(node: Node, topic: str, msg_type: type) -> None:
    """Assert that ``node`` has a publisher of ``msg_type`` on ``topic``."""
    _node_has(node, topic, msg_type, "publisher")


def node_subscribes(node: Node, topic: str, msg_type: type) -> None:
    """Assert that ``node`` has a subscription of ``msg_type`` on ``topic``."""
    _node_has(node, topic, msg_type, "subscription")


def _node_has(node: Node, topic: str, msg_type: type, kind: str) -> None:
    topic = _absolute(topic)
    lookup = (
        node.get_publisher_names_and_types_by_node
        if kind == "publisher"
        else node.get_subscriber_names_and_types_by_node
    )
    own = {name: types for name, types in lookup(node.get_name(), node.get_namespace())}
    want = type_name(msg_type)
    if topic in own and want in own[topic]:
        return
    if topic in own:
        raise AssertionError(
            f"node '{node.get_name()}' has a {kind} on {topic} of type {own[topic][0]}, "
            f"but the task asks for {want}: both ends of a topic must use the same type"
        )
    user = {t: ty for t, ty in own.items() if not t.startswith(("/rosout", "/parameter_events"))}
    seen = ", ".join(f"{t} ({', '.join(ty)})" for t, ty in sorted(user.items())) or "none"
    raise AssertionError(
        f"node '{node.get_name()}' has no {kind} on {topic} ({want}); "
        f"its {kind}s: {seen}. Check the topic name passed to "
        f"create_{kind}()."
    )


@dataclass
class Received:
    """Messages a probe received, with the probe's clock reading at each arrival."""

    messages: list[Any] = field(default_factory=list)
    times: list[float] = field(default_factory=list)

    @property
    def data(self) -> list[Any]:
        return [m.data for m in self.messages]


class Probe:
    """A subscription of the test's own, on a node of its own."""

    def __init__(
        self, topic: str, msg_type: type, qos: QoSProfile | int = 10, name: str = "probe"
    ) -> None:
        self.topic = _absolute(topic)
        self.msg_type = msg_type
        self.node = Node(f"{name}_{self.topic.strip('/').replace('/', '_')}")
        self.received = Received()
        self.sub = self.node.create_subscription(msg_type, self.topic, self._on_msg, qos)

    def _on_msg(self, msg: Any) -> None:
        self.received.messages.append(msg)
        self.received.times.append(self.node.get_clock().now().nanoseconds / 1e9)

    def wait_for_publisher(self, timeout: float = MATCH_TIMEOUT_S) -> None:
        """Wait until a publisher is matched, or fail saying why there is none."""
        if not ros.spin_until(lambda: self.sub.get_publisher_count() > 0, timeout=timeout):
            raise AssertionError(explain_silence(self.node, self.topic, self.msg_type))

    def wait_for(self, count: int, timeout: float) -> Received:
        ros.spin_until(lambda: len(self.received.messages) >= count, timeout=timeout)
        return self.received

    def close(self) -> None:
        ros.remove(self.node)


class Sender:
    """A publisher of the test's own that waits to be heard before it talks."""

    def __init__(self, topic: str, msg_type: type, qos: QoSProfile | int = 10) -> None:
        self.topic = _absolute(topic)
        self.msg_type = msg_type
        self.node = Node(f"sender_{self.topic.strip('/').replace('/', '_')}")
        self.pub = self.node.create_publisher(msg_type, self.topic, qos)

    def wait_for_subscriber(self, timeout: float = MATCH_TIMEOUT_S) -> None:
        if not ros.spin_until(lambda: self.pub.get_subscription_count() > 0, timeout=timeout):
            raise AssertionError(
                f"nobody subscribes to {self.topic} ({type_name(self.msg_type)}) after "
                f"{timeout:.0f} s. " + _graph_summary(self.node, self.topic, "subscriber")
            )

    def send(self, values: Sequence[Any], spin_between: float = 0.01) -> None:
        """Publish one message per value, letting every node run in between."""
        for value in values:
            self.pub.publish(self.msg_type(data=value))
            ros.spin_for(spin_between)

    def close(self) -> None:
        ros.remove(self.node)


def explain_silence(node: Node, topic: str, msg_type: type) -> str:
    """Why nothing is heard on ``topic``: wrong name, wrong type or nobody publishing."""
    want = type_name(msg_type)
    found = dict(node.get_topic_names_and_types())
    if topic in found and want not in found[topic]:
        return (
            f"{topic} exists but carries {', '.join(found[topic])}, not {want}: "
            "publisher and subscriber must use the same message type"
        )
    return f"no publisher on {topic} ({want}). " + _graph_summary(node, topic, "publisher")


def _graph_summary(node: Node, topic: str, kind: str) -> str:
    found = dict(node.get_topic_names_and_types())
    others = sorted(t for t in found if t != topic and not t.startswith(("/rosout", "/parameter")))
    if others:
        return (
            "Topics in the graph: "
            + ", ".join(f"{t} ({', '.join(found[t])})" for t in others)
            + f". Is the {kind} on the right topic name?"
        )
    return f"No other topics exist: was the {kind} created in __init__?"


class RosoutLog:
    """The log lines nodes send to ``/rosout`` (what ``ros2 topic echo /rosout`` shows)."""

    def __init__(self) -> None:
        self.node = Node("rosout_listener")
        self.lines: list[Log] = []
        self.node.create_subscription(Log, "/rosout", self.lines.append, QoSProfile(depth=1000))

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


def assert_sequence(name: str, got: Sequence[Any], expected: Sequence[Any]) -> None:
    """Compare a received sequence with the expected one and say how they differ."""
    got, expected = list(got), list(expected)
    if got == expected:
        return
    if not got:
        raise AssertionError(
            f"{name}: nothing was received, expected {_short(expected)}. Is a timer or "
            "subscription created in __init__, and does its callback publish?"
        )
    if sorted(got) == sorted(expected):
        raise AssertionError(f"{name}: right values in the wrong order: {_short(got)}")
    if len(got) != len(expected) and got[: len(expected)] == expected[: len(got)]:
        raise AssertionError(
            f"{name}: received {len(got)} messages, expected {len(expected)} "
            f"({_short(expected)}); got {_short(got)}. Check the timer period."
        )
    raise AssertionError(f"{name}: expected {_short(expected)}, got {_short(got)}")


def assert_relayed(
    topic: str,
    msg_type: type,
    values: Sequence[Any],
    received: Callable[[], Sequence[Any]],
    expected: Sequence[Any],
    timeout: float = 2.0,
) -> None:
    """Publish ``values`` on ``topic`` and compare ``received()`` with ``expected``."""
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
        raise AssertionError(
            f"{name}: messages arrived at t = [{shown}] s (simulated), expected one every "
            f"{expected[0]:.2f} s. Is the timer created with the `period` argument?"
        )


def assert_logged(log: RosoutLog, node_name: str, fragments: Sequence[str]) -> None:
    """Each fragment must appear in a log line of ``node_name`` (its logger, not print)."""
    ros.spin_for(0.1)
    lines = log.of(node_name)
    missing = [f for f in fragments if not any(f in line for line in lines)]
    if missing:
        raise AssertionError(
            f"node '{node_name}' logged {len(lines)} line(s) to /rosout, and none mentions "
            f"{_short(missing)}. Log each value with self.get_logger().info(...); "
            "print() output does not reach /rosout."
        )


HELLO_PREFIX = "Hello World: "


def assert_hello_world(data: Sequence[str], at_least: int) -> None:
    """Messages are 'Hello World: N' with N counting up by one."""
    if len(data) < at_least:
        raise AssertionError(
            f"received {len(data)} message(s) on /chatter, expected at least {at_least}: "
            "is the timer publishing twice a second?"
        )
    numbers = []
    for text in data:
        if not text.startswith(HELLO_PREFIX) or not text[len(HELLO_PREFIX) :].isdigit():
            raise AssertionError(
                f"received {text!r} on /chatter; each message must read 'Hello World: N'"
            )
        numbers.append(int(text[len(HELLO_PREFIX) :]))
    if any(b != a + 1 for a, b in zip(numbers, numbers[1:])):
        raise AssertionError(f"the counter in the messages must go up by one: {numbers}")


# -- node scripts run as their own process -------------------------------------------


@dataclass
class ScriptRun:
    """A Python script running as a separate process (as ``ros2 run`` would start it)."""

    proc: subprocess.Popen[str]
    path: Path
    output: str = ""

    def alive(self) -> bool:
        return self.proc.poll() is None

    def interrupt(self, timeout: float = 5.0) -> int | None:
        """Press Ctrl-C: send SIGINT and wait; ``None`` if it did not exit in time."""
        if self.alive():
            self.proc.send_signal(signal.SIGINT)
        try:
            self.output, _ = self.proc.communicate(timeout=timeout)
            return self.proc.returncode
        except subprocess.TimeoutExpired:
            return None

    def kill(self) -> None:
        """Stop the script and everything it started; collect its output (once)."""
        if self.alive():
            os.killpg(self.proc.pid, signal.SIGKILL)
        if self.proc.stdout is not None and not self.proc.stdout.closed:
            self.output += self.proc.communicate()[0] or ""


@contextmanager
def run_script(path: str | os.PathLike[str], *ros_args: str) -> Iterator[ScriptRun]:
    """Start ``python path --ros-args ...`` and make sure it is gone afterwards."""
    script = Path(path)
    if not script.exists():
        raise AssertionError(f"{script} does not exist: did you run the %%writefile cell?")
    argv = [sys.executable, "-u", str(script)]
    if ros_args:
        argv += ["--ros-args", *ros_args]
    proc = subprocess.Popen(
        argv,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    run = ScriptRun(proc, script)
    try:
        yield run
    finally:
        run.kill()


def assert_clean_exit(run: ScriptRun, timeout: float = 5.0) -> None:
    """Ctrl-C the script; it must exit with code 0 and print no traceback."""
    code = run.interrupt(timeout)
    tail = "\n".join(run.output.strip().splitlines()[-6:])
    if code is None:
        raise AssertionError(
            f"{run.path.name} was still running {timeout:.0f} s after Ctrl-C (SIGINT). "
            "Does main() catch the interrupt and return?"
        )
    if code != 0 or "Traceback" in run.output:
        hint = ""
        if "rcl_shutdown already called" in run.output or "ExternalShutdownException" in run.output:
            hint = (
                " On Jazzy, Ctrl-C shuts the context down inside spin(): catch "
                "(KeyboardInterrupt, ExternalShutdownException) and call "
                "rclpy.try_shutdown() instead of rclpy.shutdown()."
            )
        raise AssertionError(
            f"{run.path.name} did not exit cleanly on Ctrl-C: exit code {code}"
            f"{', with a traceback' if 'Traceback' in run.output else ''}.{hint}\n"
            f"Last lines it printed:\n{tail}"
        )


def wait_for_script_publisher(run: ScriptRun, probe: Probe, timeout: float = 10.0) -> None:
    """Wait until the script's publisher is matched; fail with its output if it died."""
    matched = ros.spin_until(
        lambda: probe.sub.get_publisher_count() > 0 or not run.alive(), timeout=timeout
    )
    assert_still_running(run)
    if not matched:
        raise AssertionError(
            f"{run.path.name} runs but after {timeout:.0f} s there is still "
            + explain_silence(probe.node, probe.topic, probe.msg_type)
        )


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
        raise AssertionError(
            f"{run.path.name} does not listen to /clock when started with "
            "--ros-args -p use_sim_time:=true: does main() pass its args to "
            "rclpy.init(args=args)?"
        )
    clock.advance_remote(seconds, step=step, settle=0.02)
    ros.spin_for(0.2, probe.node)
    return probe.received


def assert_still_running(run: ScriptRun) -> None:
    if not run.alive():
        run.kill()
        tail = "\n".join(run.output.strip().splitlines()[-8:])
        raise AssertionError(
            f"{run.path.name} exited by itself with code {run.proc.returncode} before "
            f"Ctrl-C; a node should spin until it is stopped. It printed:\n{tail}"
        )


# -- helpers ---------------------------------------------------------------------------


def _absolute(topic: str) -> str:
    return topic if topic.startswith("/") else "/" + topic


def _short(values: Sequence[Any], limit: int = 12) -> str:
    values = list(values)
    if len(values) <= limit:
        return repr(values)
    return repr(values[:limit])[:-1] + f", ... ({len(values)} in all)]"


def _call_args(args: tuple[Any, ...], kwargs: dict[str, Any]) -> str:
    return ", ".join([repr(a) for a in args] + [f"{k}={v!r}" for k, v in kwargs.items()])


def _where(exc: BaseException) -> str:
    frames = traceback.extract_tb(exc.__traceback__)
    if not frames:
        return "no traceback"
    last = frames[-1]
    return f"line {last.lineno}: {(last.line or '').strip()}"
