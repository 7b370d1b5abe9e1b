"""The student's code as the grader's judge sees it: handles into the student's kernel.

When a lab is graded, each test cell runs twice: in the student's kernel (without its
hidden tests; only the student's view) and, for the score, in the judge
(``autograder.judge``), a process of its own that the student's code cannot reach. There
the cell's own source runs as the instructor wrote it, with the same ``checks`` module,
but each name the student defined (a class, a function, a value) is bound to what the
kernel says it is:

- a value (numbers, strings, lists and dicts of them) is its plain data, decoded here
  (``decode``): never unpickled, never an object whose methods the student wrote;
- a class or function is a ``Student`` handle: ``checks.make_node(Handle, ...)`` builds
  the node in the kernel and returns a ``RemoteNode``, and calling a function handle
  calls it in the kernel and decodes what it returned.

The check helpers of ``rosbook.labs`` take either: a local class in the student's own
runs and ``make check``, a handle in grading (``judging()`` tells which). The judge
publishes the stimuli and ``/clock`` itself and judges the ROS traffic it records, the
exit codes of the programs it starts, and the plain data it decodes.

The kernel's side is ``rosbook.labs.agent.JudgeAgent``; this module is the judge's side
of it (the Jupyter client, ``Kernel``) and what a check sees (``Judgement``).
"""

from __future__ import annotations

import ast
import json
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import AbstractContextManager, ExitStack, contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import rclpy
from rclpy.context import Context
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock

from rosbook.labs.probes import CheckFailed, ScriptRun, run_script
from rosbook.runtime.isolation import reserve_domain
from rosbook.runtime.session import ros

#: Generous wall-clock guards against hangs; hitting one is reported as "timeout".
KERNEL_REPLY_GUARD_S = 60.0
EVENT_GUARD_S = 10.0


class JudgeTimeout(Exception):
    """A hang guard was hit: the verdict is "timeout", never "wrong"."""


class KernelError(CheckFailed):
    """The kernel raised while the agent ran the student's code."""


#: Run silently in the student's kernel before the judge's first call: the agent
#: (``rosbook.labs.agent``) as ``__rosbook_judge__``. It runs as the student, so it may
#: be changed or broken by the student's code: that can only make the judge see less,
#: and seeing less never passes a check.
LOAD_AGENT = "__rosbook_judge__ = __import__('rosbook.labs.agent', fromlist=['_']).JudgeAgent()"


class Kernel:
    """A Jupyter client of the judge's own, connected to the student's kernel."""

    def __init__(self, connection_file: str) -> None:
        from jupyter_client.blocking import BlockingKernelClient

        self.client = BlockingKernelClient(connection_file=connection_file)
        self.client.load_connection_file()
        # No heartbeat: a reply's guard already tells a dead kernel, and the heartbeat's
        # thread kept making sockets for a kernel that was gone (zmq: too many open files)
        self.client.start_channels(hb=False)
        self.agent_ready = False

    def call(self, method: str, *args: Any, guard: float = KERNEL_REPLY_GUARD_S) -> Any:
        """Run ``__rosbook_judge__.method(*args)`` in the kernel; its JSON answer."""
        return self.answer(self.send(method, *args), guard)

    def send(self, method: str, *args: Any) -> str:
        """Start ``__rosbook_judge__.method(*args)`` in the kernel; ``answer`` waits for it."""
        self._agent()
        call = f"__rosbook_judge__.{method}({', '.join(repr(a) for a in args)})"
        return self.client.execute(  # type: ignore[no-any-return]
            call,
            silent=True,
            store_history=False,
            user_expressions={"reply": "__rosbook_judge__.take_reply()"},
        )

    def _agent(self) -> None:
        if not self.agent_ready:
            self._reply(self.client.execute(LOAD_AGENT, silent=True, store_history=False), 60.0)
            self.agent_ready = True

    def answer(self, msg_id: str, guard: float = KERNEL_REPLY_GUARD_S) -> Any:
        reply = self._reply(msg_id, guard)
        answer = reply.get("user_expressions", {}).get("reply", {})
        if answer.get("status") != "ok":
            raise CheckFailed("the kernel gave no answer to the judge")
        try:
            text = ast.literal_eval(answer["data"]["text/plain"])
            if text is None:  # the call did not run: the kernel ran something else
                raise CheckFailed("the kernel gave no answer to the judge")
            return json.loads(text)
        except (KeyError, ValueError, SyntaxError, TypeError):
            raise CheckFailed("the kernel's answer to the judge was not readable") from None

    def _reply(self, msg_id: str, guard: float) -> dict[str, Any]:
        deadline = time.monotonic() + guard
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise JudgeTimeout(f"the kernel did not answer within {guard:.0f} s")
            try:
                msg = self.client.get_shell_msg(timeout=remaining)
            except Exception:  # queue.Empty: checked against the deadline above
                continue
            if msg["parent_header"].get("msg_id") == msg_id:
                content = msg["content"]
                if content.get("status") == "error":
                    raise KernelError(f"{content.get('ename')}: {content.get('evalue')}")
                return content

    def close(self) -> None:
        self.client.stop_channels()


# -- what crosses from the kernel: plain data ------------------------------------------


class Unreadable:
    """A value the kernel could only describe (its type and repr): never equal to one."""

    def __init__(self, type_name: str, text: str) -> None:
        self.type_name, self.text = type_name, text

    def __repr__(self) -> str:
        return f"{self.text} ({self.type_name})"


def decode(plain: dict[str, Any]) -> Any:
    """A value from the agent's ``plain`` form: JSON data only (numbers, strings, None,
    lists, dicts with string keys, sets of strings); else an ``Unreadable``."""
    if "repr" in plain:
        return Unreadable(plain["type"], plain["repr"])
    if "items" in plain:
        return frozenset(plain["items"])
    if "tuple" in plain:
        return tuple(decode(v) for v in plain["tuple"])
    if "list" in plain:
        return [decode(v) for v in plain["list"]]
    if "dict" in plain:
        return {str(k): decode(v) for k, v in plain["dict"]}
    value = plain.get("value")
    return value if type(value) in (bool, int, float, str) else None


def encode(value: Any) -> Any:
    """An argument for the student's code, as JSON the agent rebuilds
    (``rosbook.labs.agent.argument``): plain data, and rclpy ``Parameter``s."""
    from rclpy.parameter import Parameter

    if isinstance(value, Parameter):
        return {"parameter": [value.name, encode(value.value)]}
    if hasattr(value, "dtype") and hasattr(value, "tolist"):  # a numpy number or array
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [encode(v) for v in value]
    return value


# -- the student's names ---------------------------------------------------------------


class Student:
    """A handle to the student's global ``name`` in the kernel (a class, a function or
    another object): it never holds the object, only its name."""

    def __init__(self, name: str, kind: str) -> None:
        self.__name__ = self.name = name
        self.kind = kind

    def __repr__(self) -> str:
        return self.name

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        """A class: its node, built in the kernel (``Judgement.start_node``, keyword
        arguments only). A function: called in the kernel; what it returned, as data."""
        j = judgement()
        if self.kind == "class":
            if args:
                raise TypeError(f"{self.name}(): pass its arguments by name when graded")
            return j.start_node(self, sim_time=ros.sim_time, **kwargs)
        return j.call_function(self.name, *args, **kwargs)


def is_student(value: Any) -> bool:
    """Whether ``value`` is a handle to the student's code in a kernel (grading)."""
    return isinstance(value, (Student, RemoteNode))


class RemoteNode:
    """The student's node, built and spun in the kernel by the agent: what it said it is
    (name, namespace, endpoints) and its attributes, read when asked, as plain data."""

    def __init__(self, info: dict[str, Any], call: str) -> None:
        self._info, self.call = info, call

    def get_name(self) -> str:
        return str(self._info["name"])

    def get_namespace(self) -> str:
        return str(self._info["namespace"])

    def get_fully_qualified_name(self) -> str:
        return f"{self.get_namespace().rstrip('/')}/{self.get_name()}"

    def get_publisher_names_and_types_by_node(
        self, name: str, namespace: str
    ) -> list[tuple[str, list[str]]]:
        return [(t, list(ty)) for t, ty in self._info["publishers"]]

    def get_subscriber_names_and_types_by_node(
        self, name: str, namespace: str
    ) -> list[tuple[str, list[str]]]:
        return [(t, list(ty)) for t, ty in self._info["subscriptions"]]

    def get_service_names_and_types_by_node(
        self, name: str, namespace: str
    ) -> list[tuple[str, list[str]]]:
        return [(s, list(ty)) for s, ty in self._info["services"]]

    def __getattr__(self, attribute: str) -> Any:
        if attribute.startswith("_"):
            raise AttributeError(attribute)
        kernel = judgement().kernel
        try:
            answer = kernel.call("attribute", attribute)
        except KernelError as exc:
            if "AttributeError" in str(exc):
                raise AttributeError(f"the node has no attribute {attribute!r}") from None
            raise
        if answer.get("method"):

            def method(*args: Any) -> Any:
                try:
                    said = kernel.call("call_method", attribute, [encode(a) for a in args])
                except KernelError as exc:
                    raise CheckFailed(f"{self.get_name()}.{attribute}() raised {exc}") from None
                return decode(said)

            return method
        return decode(answer)

    def __repr__(self) -> str:
        return f"<node '{self.get_name()}' in the student's kernel>"


# -- what a check sees -----------------------------------------------------------------


@dataclass
class Judgement:
    """One test cell's view: the kernel, the submission's folder, and what it showed."""

    kernel: Kernel
    folder: Path
    #: Turns a command (paths as the judge sees them) into the one that runs it where
    #: the student's code runs: in the kernel's sandbox, as the student.
    wrap: Callable[[list[str]], list[str]] = list
    #: What the check showed (``show``), as nbformat outputs for the verdict.
    outputs: list[dict[str, Any]] = field(default_factory=list)
    #: The grader's limit on one cell (its ``--timeout``), if given.
    cell_timeout: float | None = None
    #: The student's node the cell started in the kernel (``start_node``), if any.
    started: RemoteNode | None = None
    #: What the cell's checks leave to undo when it ends (lab 6's scratch build folder,
    #: used by the checks after the one that made it): closed by the judge.
    ends: ExitStack = field(default_factory=ExitStack)
    #: What keeps the started node going in the kernel (a lockstep clock it follows,
    #: which occupies the kernel meanwhile): ended before another node starts and with
    #: the cell, with the cell's exception if it raised.
    running: ExitStack = field(default_factory=ExitStack)

    def guard(self, generous: float) -> float:
        """``generous`` seconds, or the cell's limit if that is shorter."""
        return min(generous, self.cell_timeout or generous)

    def show(self, shown: Any) -> None:
        """Show ``shown`` (anything IPython displays) in the test cell's output."""
        from IPython.core.formatters import DisplayFormatter

        data, metadata = DisplayFormatter().format(shown)
        self.outputs.append({"output_type": "display_data", "data": data, "metadata": metadata})

    def bind(self, names: Sequence[str]) -> dict[str, Any]:
        """What each of ``names`` is in the kernel: plain data for a value, a ``Student``
        handle for a class, a function or another object; a name the kernel lacks is
        left out (the cell then fails on it as it would in the kernel)."""
        if not names:
            return {}
        described = self.kernel.call("describe", list(names))
        bound: dict[str, Any] = {}
        for name, what in zip(names, described):
            kind = what.get("kind")
            if kind == "value":
                bound[name] = decode(what["plain"])
            elif kind in ("class", "function", "object"):
                bound[name] = Student(name, kind)
        return bound

    def start_node(
        self,
        factory: Student,
        *,
        sim_time: bool = False,
        parameters: dict[str, Any] | None = None,
        **kwargs: Any,
    ) -> RemoteNode:
        """Build ``factory(**kwargs)`` in the kernel (``parameters``: its overrides)."""
        shown = [f"{k}={v!r}" for k, v in kwargs.items()]
        shown += [f"Parameter({k!r}, value={v!r})" for k, v in (parameters or {}).items()]
        call = f"{factory.name}({', '.join(shown)})"
        self.running.close()  # the kernel is free again for the next node
        # The endpoints of the cell's last node, which the kernel destroys now: until the
        # judge's side has seen them go, its endpoints may count them as matched (a
        # publisher "heard" by the old node's subscription sends the new one nothing).
        stale: set[str] = set()
        if self.started is not None:
            watcher = ros_node("judge_graph_gids")
            try:
                stale = endpoint_gids(watcher, self.started.get_name())
            finally:
                ros.remove(watcher)
        try:
            info = self.kernel.call(
                "start", factory.name, kwargs, sim_time, parameters, not sim_time
            )
        except KernelError as exc:
            if "NotImplementedError" in str(exc):
                raise CheckFailed(
                    f"{call}: this task is not done yet (NotImplementedError)"
                ) from None
            raise CheckFailed(f"{call} raised {exc}") from None
        # One participant of the judge's from now to the cell's end: made after the
        # kernel's node, so a kernel making its participant again (a switch of time
        # source) never has one of the judge's about (held from the judge's start, it
        # left the sandboxed kernel unable to send its replies; the cause is not known).
        ros.hold_participant()
        if stale:
            watcher = ros_node("judge_graph_gone")
            try:  # a guard only: past it, the checks' own waits still hold
                ros.spin_until(
                    lambda: not stale & endpoint_gids(watcher), watcher, timeout=EVENT_GUARD_S
                )
            finally:
                ros.remove(watcher)
        self.started = RemoteNode(info, call)
        return self.started

    def value(self, name: str) -> Any:
        """The kernel's global ``name``, as plain data."""
        try:
            return decode(self.kernel.call("get", name))
        except KernelError as exc:
            if "KeyError" in str(exc):
                raise CheckFailed(
                    f"{name} is not defined: write it in its task's cell and run it"
                ) from None
            raise

    def call_function(self, name: str, *args: Any, **kwargs: Any) -> Any:
        """What the student's function ``name(*args, **kwargs)`` returns, called in the
        kernel (arguments: plain data, ``encode``)."""
        shown = ", ".join(
            [repr(a) if not isinstance(a, str) or len(a) < 80 else "<text>" for a in args]
            + [f"{k}={v!r}" for k, v in kwargs.items()]
        )
        try:
            return decode(
                self.kernel.call(
                    "call",
                    name,
                    [encode(a) for a in args],
                    {k: encode(v) for k, v in kwargs.items()},
                )
            )
        except KernelError as exc:
            if "KeyError" in str(exc) and name in str(exc):
                raise CheckFailed(f"{name} is not defined: run its task's cell") from None
            if "NotImplementedError" in str(exc):
                raise CheckFailed(
                    f"{name}({shown}): this task is not done yet (NotImplementedError)"
                ) from None
            raise CheckFailed(f"{name}({shown}) raised {exc}") from None

    def wait_on_graph(self, name: str, topic: str, kind: str) -> None:
        """Wait until the judge sees node ``name``'s ``kind`` ("publisher"/"subscription")
        of ``topic`` on the DDS graph, so no message of the check is sent into the void."""
        watcher = ros_node("judge_graph")
        lookup = (
            watcher.get_publisher_names_and_types_by_node
            if kind == "publisher"
            else watcher.get_subscriber_names_and_types_by_node
        )

        def seen() -> bool:
            try:
                return any(t == topic for t, _ in lookup(name, "/"))
            except Exception:  # NodeNameNonExistentError until discovery finds it
                return False

        try:
            if not ros.spin_until(seen, watcher, timeout=EVENT_GUARD_S):
                raise JudgeTimeout(f"node '{name}' did not appear on the ROS graph")
        finally:
            ros.remove(watcher)

    def await_known(self, node: Node, topic: str, kind: str) -> None:
        """Wait until the kernel's node has discovered ``node``'s ``kind`` ("publisher"
        or "subscription") on ``topic``. Discovery runs on each side on its own: the
        judge's side matching says nothing of the kernel's, and what is sent before the
        kernel's side knows the other end is lost, not late."""
        infos = (
            node.get_publishers_info_by_topic(topic)
            if kind == "publisher"
            else node.get_subscriptions_info_by_topic(topic)
        )
        mine = [bytes(e.endpoint_gid).hex() for e in infos if e.node_name == node.get_name()]
        guard = 3 * EVENT_GUARD_S
        method = "await_writers" if kind == "publisher" else "await_readers"
        if not self.kernel.call(method, topic, mine, guard, guard=guard + KERNEL_REPLY_GUARD_S):
            raise JudgeTimeout(
                f"the student's node did not discover the judge's {kind} on {topic} "
                f"after {guard:.0f} s"
            )

    def script(
        self, name: str, *ros_args: str, domain: int | None = None
    ) -> AbstractContextManager[ScriptRun]:
        """Start the student's program ``name`` (``python name --ros-args ...``) from the
        judge, in the kernel's sandbox, so its exit code is the judge's to read; it is
        gone afterwards. ``domain``: the ROS domain it runs in (default: the judge's)."""
        import os

        env = None if domain is None else {**os.environ, "ROS_DOMAIN_ID": str(domain)}
        return run_script(self.folder / name, *ros_args, cwd=self.folder, wrap=self.wrap, env=env)


def endpoint_gids(watcher: Node, node_name: str | None = None) -> set[str]:
    """The GIDs of every topic endpoint on ``watcher``'s graph (of ``node_name``'s only)."""
    found = set()
    for topic, _ in watcher.get_topic_names_and_types():
        for e in [
            *watcher.get_publishers_info_by_topic(topic),
            *watcher.get_subscriptions_info_by_topic(topic),
        ]:
            if node_name is None or e.node_name == node_name:
                found.add(bytes(e.endpoint_gid).hex())
    return found


_judging: ContextVar[Judgement | None] = ContextVar("judging", default=None)


def judging() -> Judgement | None:
    """The test cell the judge runs now, or None (the student's kernel, ``make check``)."""
    return _judging.get()


def judgement() -> Judgement:
    """The test cell the judge runs now (only a handle's methods call this)."""
    j = _judging.get()
    if j is None:
        raise RuntimeError("a handle to the student's kernel is used outside the judge")
    return j


@contextmanager
def judging_cell(j: Judgement) -> Iterator[Judgement]:
    """Run a test cell's checks against the kernel of ``j`` inside this block."""
    token = _judging.set(j)
    try:
        with j.running:
            yield j
    finally:
        _judging.reset(token)


# -- the judge's own nodes -------------------------------------------------------------


def drain(node: Node, rounds: int = 20) -> None:
    """Run ``node``'s callbacks that are ready now (messages that have arrived)."""
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    try:
        for _ in range(rounds):
            executor.spin_once(timeout_sec=0.0)
    finally:
        executor.remove_node(node)
        executor.shutdown(timeout_sec=0)


def ros_node(name: str, context: Context | None = None) -> Node:
    """A node of the judge's own (destroyed with ``ros.remove``), in ``context`` (default:
    the session's), without parameter services (nobody asks the judge's nodes)."""
    return Node(name, context=context, start_parameter_services=False)


@contextmanager
def own_domain() -> Iterator[tuple[int, Context]]:
    """A ROS domain of its own and an rclpy context in it, for a part of a check that
    runs alongside another (in a thread): the two parts' traffic never meets. The
    context's nodes must be destroyed before the block ends."""
    with reserve_domain() as domain:
        context = Context()
        rclpy.init(context=context, domain_id=domain.domain_id)
        try:
            yield domain.domain_id, context
        finally:
            context.try_shutdown()


def clock_publisher(node: Node) -> Any:
    quiet = PublisherEventCallbacks(use_default_callbacks=False)
    return node.create_publisher(Clock, "/clock", QoSProfile(depth=10), event_callbacks=quiet)


def clock_message(t: float) -> Clock:
    msg = Clock()
    msg.clock.sec, msg.clock.nanosec = divmod(int(round(t * 1e9)), 1_000_000_000)
    return msg
