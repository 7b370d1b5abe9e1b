"""Checks that lab test cells run against a student's real nodes.

Every failure is a ``CheckFailed`` (an ``AssertionError``) whose message says what was
expected, what was seen and the likely ROS cause (topic name, message type, not
publishing, not exiting cleanly), so a student's feedback names the mistake without
showing hidden test code. In a notebook it shows that message first, then only the
student's own lines, not the library's frames.

In IPython, a cell that calls a checks module leaves the kernel as it found it: the
nodes it made (probes, the student's nodes it built) are destroyed when the cell ends,
and a simulated clock it started (``ros.sim_clock()``) gives way to wall time again, so
the next "try it" cell's timers fire as before the check (``restore_after_checks``).

When grading, a test cell's checks raise ``CheckDeferred`` in the kernel instead of
running (``rosbook.labs.deferral``): the grader decides that cell outside the kernel.
"""

from __future__ import annotations

import ast
import os
import signal
import subprocess
import sys
import sysconfig
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any, TypeVar

from rclpy.node import Node
from rclpy.qos import QoSCompatibility, QoSProfile, qos_check_compatible

from rosbook.labs.deferral import deferrable
from rosbook.runtime.graph import absolute_name
from rosbook.runtime.session import ros

T = TypeVar("T")

#: Wall-clock bound for discovery between two endpoints in one process.
MATCH_TIMEOUT_S = 2.0
#: Wall-clock hang guard for a match the graph shows is coming (an endpoint of the right
#: type and a compatible QoS is there): a loaded machine can take seconds to match two
#: endpoints, even in one process. Passing it is a timeout, never a wrong answer.
MATCH_GUARD_S = 30.0

#: Where the library's own frames live: hidden from a failing check's traceback.
_LIBRARY_DIRS = tuple(
    str(Path(p).resolve())
    for p in {
        Path(__file__).resolve().parents[__name__.count(".") - 1],  # the rosbook package
        sysconfig.get_paths()["stdlib"],
        sysconfig.get_paths()["purelib"],
        sysconfig.get_paths()["platlib"],
    }
)


class CheckFailed(AssertionError):
    """A check that did not pass. Its message is the whole explanation.

    IPython shows its message first, followed by the lines of the student's own code
    (the check cell, their classes) that led there; the library's frames are left out
    (``_render_traceback_``). nbgrader and ``make check`` read the same message.
    """

    def _render_traceback_(self) -> list[str]:
        lines = [f"{type(self).__name__}: {self}"]
        own = [frame for frame in traceback.extract_tb(self.__traceback__) if _own_code(frame)]
        if own:
            lines.append("")
            lines.append("in your notebook (library frames hidden):")
            lines.extend(f"  {_cell_name(f.filename)}, line {f.lineno}: {f.line}" for f in own)
        return lines


def _own_code(frame: traceback.FrameSummary) -> bool:
    """A frame of the student's notebook or files, not of this library or an installed one."""
    path = str(Path(frame.filename).resolve()) if not frame.filename.startswith("<") else ""
    return not path.startswith(_LIBRARY_DIRS) and "site-packages" not in path


def _cell_name(filename: str) -> str:
    """``Cell In[5]`` for a notebook cell's file, as IPython names it; else the file."""
    shell = _ipython()
    named = shell.compile.format_code_name(filename) if shell is not None else None
    return " ".join(named) if named else filename


def _ipython() -> Any | None:
    """The running IPython shell, if this is one."""
    try:
        from IPython import get_ipython
    except ImportError:
        return None
    return get_ipython()


# -- a cell that runs checks leaves the kernel as it found it ---------------------------


def _uses_checks(source: str, namespace: dict[str, Any]) -> bool:
    """Whether ``source`` calls into a rosbook checks module bound in ``namespace``."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return False
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            value = namespace.get(node.value.id)
            name = getattr(value, "__name__", "") if isinstance(value, ModuleType) else ""
            if name.startswith("rosbook.labs."):  # a lab's checks, or the shared probes
                return True
    return False


class CellRestore:
    """IPython hooks: a cell that calls the checks undoes what it did to the session.

    Before such a cell runs, the session's time source and live nodes are noted; after
    it (passed, failed or interrupted), the nodes it made are destroyed and, if it
    switched the session to simulated time, the session goes back to wall time. Other
    cells are left alone: a student's own ``ros.sim_clock()`` outlives its cell.
    """

    def __init__(self, shell: Any) -> None:
        self.shell = shell
        self.before: tuple[bool, list[Node]] | None = None

    def pre_run_cell(self, info: Any) -> None:
        source = getattr(info, "raw_cell", "") or ""
        if _uses_checks(source, self.shell.user_ns):
            self.before = (ros.sim_time, ros.nodes)
        else:
            self.before = None

    def post_run_cell(self, result: Any) -> None:
        if self.before is None:
            return
        sim_time, nodes = self.before
        self.before = None
        if ros.sim_time and not sim_time:
            ros.init(sim_time=False)  # every node of the sim-time context goes with it
            return
        for node in ros.nodes:
            if not any(node is old for old in nodes):
                ros.remove(node)


def restore_after_checks(shell: Any | None = None) -> CellRestore | None:
    """Install ``CellRestore`` in ``shell`` (default: the running IPython), once."""
    shell = shell or _ipython()
    if shell is None:
        return None
    for hook in shell.events.callbacks["pre_run_cell"]:
        if isinstance(getattr(hook, "__self__", None), CellRestore):
            return hook.__self__
    restore = CellRestore(shell)
    shell.events.register("pre_run_cell", restore.pre_run_cell)
    shell.events.register("post_run_cell", restore.post_run_cell)
    return restore


def make_node(factory: Callable[..., T], *args: Any, **kwargs: Any) -> T:
    """Build the student's node, turning a crash into a message that says where. When
    graded, ``factory`` is a handle (``rosbook.labs.remote``): the node is built in the
    student's kernel, on the session's time source, and what comes back is its
    ``RemoteNode``."""
    from rosbook.labs import remote

    if isinstance(factory, remote.Student):
        if args:
            raise TypeError("make_node: pass a node's arguments by name when it is graded")
        return remote.judgement().start_node(factory, sim_time=ros.sim_time, **kwargs)  # type: ignore[return-value]
    call = f"{getattr(factory, '__name__', factory)}({_call_args(args, kwargs)})"
    try:
        return factory(*args, **kwargs)
    except NotImplementedError:
        raise CheckFailed(f"{call}: this task is not done yet (NotImplementedError)") from None
    except Exception as exc:  # the student's constructor failed: say how
        raise CheckFailed(f"{call} raised {type(exc).__name__}: {exc} ({_where(exc)})") from None


def show(shown: Any) -> None:
    """Show ``shown`` (anything IPython displays: a figure, a scene) in the test cell's
    output: the notebook's, or when graded the judge's verdict (``Judgement.show``),
    which the feedback shows in the cell's place."""
    from rosbook.labs import remote

    j = remote.judging()
    if j is not None:
        j.show(shown)
        return
    from IPython.display import display

    display(shown)


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
    lookup = (
        node.get_publisher_names_and_types_by_node
        if kind == "publisher"
        else node.get_subscriber_names_and_types_by_node
    )
    own = lookup(node.get_name(), node.get_namespace())
    assert_endpoint(node.get_name(), own, topic, msg_type, kind)


def assert_endpoint(
    node_name: str,
    own: Sequence[tuple[str, Sequence[str]]],
    topic: str,
    msg_type: type,
    kind: str,
) -> None:
    """``own`` (a node's (topic, types) of ``kind``) holds ``topic`` of ``msg_type``."""
    topic = absolute_name(topic)
    endpoints = {name: list(types) for name, types in own}
    want = type_name(msg_type)
    if topic in endpoints and want in endpoints[topic]:
        return
    if topic in endpoints:
        raise CheckFailed(
            f"node '{node_name}' has a {kind} on {topic} of type {endpoints[topic][0]}, "
            f"but the task asks for {want}: both ends of a topic must use the same type"
        )
    user = {
        t: ty for t, ty in endpoints.items() if not t.startswith(("/rosout", "/parameter_events"))
    }
    seen = ", ".join(f"{t} ({', '.join(ty)})" for t, ty in sorted(user.items())) or "none"
    raise CheckFailed(
        f"node '{node_name}' has no {kind} on {topic} ({want}); "
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
        self.topic = absolute_name(topic)
        self.msg_type = msg_type
        self.node = Node(f"{name}_{self.topic.strip('/').replace('/', '_')}")
        self.received = Received()
        self.sub = self.node.create_subscription(msg_type, self.topic, self._on_msg, qos)

    def _on_msg(self, msg: Any) -> None:
        self.received.messages.append(msg)
        self.received.times.append(self.node.get_clock().now().nanoseconds / 1e9)

    def wait_for_publisher(self, timeout: float = MATCH_TIMEOUT_S) -> None:
        """Wait until a publisher is matched, or fail saying why there is none
        (``await_match``); when graded, also until the student's node in the kernel
        knows this subscription (it sends only to those it knows)."""
        if not await_match(self.node, self.topic, self.msg_type, self.sub.qos_profile,
                           lambda: self.sub.get_publisher_count() > 0, timeout):  # fmt: skip
            raise CheckFailed(explain_silence(self.node, self.topic, self.msg_type))
        _known_in_kernel(self.node, self.topic, "subscription")

    def wait_for(self, count: int, timeout: float) -> Received:
        ros.spin_until(lambda: len(self.received.messages) >= count, timeout=timeout)
        return self.received

    def close(self) -> None:
        ros.remove(self.node)


class Sender:
    """A publisher of the test's own that waits to be heard before it talks."""

    def __init__(self, topic: str, msg_type: type, qos: QoSProfile | int = 10) -> None:
        self.topic = absolute_name(topic)
        self.msg_type = msg_type
        self.node = Node(f"sender_{self.topic.strip('/').replace('/', '_')}")
        self.pub = self.node.create_publisher(msg_type, self.topic, qos)

    def wait_for_subscriber(self, timeout: float = MATCH_TIMEOUT_S) -> None:
        """Wait until a subscription is matched, or fail saying why there is none
        (``await_match``)."""
        if not await_match(self.node, self.topic, self.msg_type, self.pub.qos_profile,
                           lambda: self.pub.get_subscription_count() > 0, timeout,
                           publishing=True):  # fmt: skip
            raise CheckFailed(
                f"nobody subscribes to {self.topic} ({type_name(self.msg_type)}) after "
                f"{timeout:.0f} s. " + _graph_summary(self.node, self.topic, "subscriber")
            )
        _known_in_kernel(self.node, self.topic, "publisher")

    def send(self, values: Sequence[Any], spin_between: float = 0.01) -> None:
        """Publish one message per value, letting every node run in between."""
        for value in values:
            self.pub.publish(self.msg_type(data=value))
            ros.spin_for(spin_between)

    def close(self) -> None:
        ros.remove(self.node)


def _known_in_kernel(node: Node, topic: str, kind: str) -> None:
    """When graded with the student's node in the kernel: wait until that node knows
    ``node``'s ``kind`` on ``topic`` (discovery runs on each side on its own)."""
    from rosbook.labs import remote

    j = remote.judging()
    if j is not None and j.started is not None:
        j.await_known(node, topic, kind)


def await_match(
    node: Node,
    topic: str,
    msg_type: type,
    qos: QoSProfile,
    matched: Callable[[], bool],
    timeout: float,
    publishing: bool = False,
) -> bool:
    """Spin until ``matched()`` (``node``'s endpoint on ``topic`` met the other side);
    whether it did. Past ``timeout``, while the graph shows an endpoint of the other side
    with the right type and a QoS compatible with ``qos`` (one that will match, only
    late), it waits on up to ``MATCH_GUARD_S`` and then raises ``TimeoutError``."""
    if ros.spin_until(matched, timeout=timeout):
        return True
    want = type_name(msg_type)
    others = (
        node.get_subscriptions_info_by_topic(topic)
        if publishing
        else node.get_publishers_info_by_topic(topic)
    )
    coming = [
        e
        for e in others
        if e.topic_type == want
        and _compatible(*((qos, e.qos_profile) if publishing else (e.qos_profile, qos)))
    ]
    if not coming:
        return False
    if ros.spin_until(matched, timeout=MATCH_GUARD_S):
        return True
    kind = "subscription" if publishing else "publisher"
    raise TimeoutError(
        f"timeout: node '{coming[0].node_name}' has a {kind} on {topic} ({want}) on the ROS "
        f"graph, but it did not match within {timeout + MATCH_GUARD_S:g} s"
    )


def _compatible(publisher: QoSProfile, subscription: QoSProfile) -> bool:
    return bool(qos_check_compatible(publisher, subscription)[0] != QoSCompatibility.ERROR)


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


def assert_sequence(name: str, got: Sequence[Any], expected: Sequence[Any]) -> None:
    """Compare a received sequence with the expected one and say how they differ."""
    got, expected = list(got), list(expected)
    if got == expected:
        return
    if not got:
        raise CheckFailed(
            f"{name}: nothing was received, expected {_short(expected)}. Is a timer or "
            "subscription created in __init__, and does its callback publish?"
        )
    if sorted(got) == sorted(expected):
        raise CheckFailed(f"{name}: right values in the wrong order: {_short(got)}")
    if len(got) != len(expected) and got[: len(expected)] == expected[: len(got)]:
        raise CheckFailed(
            f"{name}: received {len(got)} messages, expected {len(expected)} "
            f"({_short(expected)}); got {_short(got)}. Check the timer period."
        )
    raise CheckFailed(f"{name}: expected {_short(expected)}, got {_short(got)}")


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
def run_script(
    path: str | os.PathLike[str],
    *ros_args: str,
    cwd: str | os.PathLike[str] | None = None,
    wrap: Callable[[list[str]], list[str]] = list,
    env: Mapping[str, str] | None = None,
) -> Iterator[ScriptRun]:
    """Start ``python path --ros-args ...`` and make sure it is gone afterwards.

    ``wrap`` turns the command into the one actually run (the grader's judge runs a
    student's script through it); ``env``: its environment (default: this process's)."""
    from rosbook.labs import remote

    j = remote.judging()
    if j is not None:  # graded: the student's folder, run as the student, in the sandbox
        script = j.folder / path
        cwd, wrap = j.folder, j.wrap
    script = Path(path) if j is None else script
    if not script.exists():
        raise CheckFailed(f"{script.name} does not exist: did you run the %%writefile cell?")
    argv = [sys.executable, "-u", str(script)]
    if ros_args:
        argv += ["--ros-args", *ros_args]
    with run_program(argv, cwd=cwd, wrap=wrap, path=script, env=env) as run:
        yield run


@contextmanager
def run_program(
    argv: list[str],
    cwd: str | os.PathLike[str] | None = None,
    wrap: Callable[[list[str]], list[str]] = list,
    path: Path | None = None,
    stdin: bool = False,
    env: Mapping[str, str] | None = None,
) -> Iterator[ScriptRun]:
    """Start ``wrap(argv)`` in a process group of its own (output merged, ``stdin``: a
    pipe to write to) and make sure it and what it started are gone afterwards."""
    proc = subprocess.Popen(
        wrap(argv),
        cwd=cwd,
        env=env,
        stdin=subprocess.PIPE if stdin else subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    run = ScriptRun(proc, path or Path(argv[0]))
    try:
        yield run
    finally:
        run.kill()


class TimedOut(CheckFailed):
    """A wall-clock guard was hit while waiting for an event: a hang, or a starved
    machine. A grader reports it as a timeout, never as wrong."""


class StillRunning(TimedOut):
    """A script outlived the wall-clock guard after Ctrl-C: a hang, or a starved machine.
    The guard cannot tell which, so a grader reports it as a timeout, never as wrong."""


#: Wall-clock seconds a script may take to exit after Ctrl-C: a generous hang guard.
EXIT_GUARD_S = 15.0


RCLPY_SIGINT_RACE = "the given context is not valid"
RCLPY_TRY_SHUTDOWN_RACE = ("in try_shutdown", "rcl_shutdown already called on the given context")


def rclpy_raced(output: str) -> bool:
    """Whether a node's ``output`` ends in rclpy's own Ctrl-C race (its signal handler
    shut the context down from a thread of its own, while spin() built its next wait set
    or while main's ``rclpy.try_shutdown()`` shut it down too), not in a mistake of its
    code: ``rclpy.shutdown()`` after Ctrl-C fails every time, and says "rcl_shutdown
    already called" from ``shutdown``, not ``try_shutdown``. The judges run such a check
    once more (``autograder/judge.py``)."""
    return RCLPY_SIGINT_RACE in output or all(part in output for part in RCLPY_TRY_SHUTDOWN_RACE)


def assert_clean_exit(run: ScriptRun, timeout: float = EXIT_GUARD_S) -> None:
    """Ctrl-C the script; it must exit with code 0 and print no traceback."""
    code = run.interrupt(timeout)
    tail = "\n".join(run.output.strip().splitlines()[-6:])
    if code is None:
        raise StillRunning(
            f"{run.path.name} was still running {timeout:.0f} s after Ctrl-C (SIGINT). "
            "Unless the machine was very busy: does main() catch the interrupt and return?"
        )
    if code != 0 or "Traceback" in run.output:
        hint = ""
        if (
            "rcl_shutdown already called" in run.output and not rclpy_raced(run.output)
        ) or "ExternalShutdownException" in run.output:
            hint = (
                " On Jazzy, Ctrl-C shuts the context down inside spin(): catch "
                "(KeyboardInterrupt, ExternalShutdownException) and call "
                "rclpy.try_shutdown() instead of rclpy.shutdown()."
            )
        raise CheckFailed(
            f"{run.path.name} did not exit cleanly on Ctrl-C: exit code {code}"
            f"{', with a traceback' if 'Traceback' in run.output else ''}.{hint}\n"
            f"Last lines it printed:\n{tail}"
        )


def wait_for_script_publisher(run: ScriptRun, probe: Probe, timeout: float = 30.0) -> None:
    """Wait until the script's publisher is matched; fail with its output if it died."""
    matched = ros.spin_until(
        lambda: probe.sub.get_publisher_count() > 0 or not run.alive(), timeout=timeout
    )
    assert_still_running(run)
    if not matched:
        raise CheckFailed(
            f"{run.path.name} runs but after {timeout:.0f} s there is still "
            + explain_silence(probe.node, probe.topic, probe.msg_type)
        )


# -- helpers ---------------------------------------------------------------------------


def assert_still_running(run: ScriptRun) -> None:
    if not run.alive():
        run.kill()
        tail = "\n".join(run.output.strip().splitlines()[-8:])
        raise CheckFailed(
            f"{run.path.name} exited by itself with code {run.proc.returncode} before "
            f"Ctrl-C; a node should spin until it is stopped. It printed:\n{tail}"
        )


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


restore_after_checks()
deferrable(globals())
