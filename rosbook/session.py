"""A notebook-safe rclpy session: one context per kernel, bounded spinning, simulated time.

A notebook cell can be run again, in any order, without "context already initialized",
duplicate nodes or a hung kernel::

    from rosbook import ros

    ros.init()                                   # idempotent
    talker = Talker()                            # a node made by an earlier run of
                                                 # this cell under the same name is gone
    ros.spin_for(2.0)                            # every node of the session, for 2 s
    ros.spin_until(lambda: len(got) >= 3, timeout=5.0)

rclpy is initialised *without* its signal handlers: in a Jupyter kernel a SIGINT is the
user interrupting a cell (Python's own ``KeyboardInterrupt``), and rclpy's handler would
instead shut the context down, leaving every later cell with ``NotInitializedException``.
The session also recovers by itself when something else shut its context down.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterable
from typing import Any

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock

#: Period of the busy check inside ``spin_until`` (seconds of wall time).
POLL_S = 0.01


class Session:
    """The kernel's single rclpy context and the nodes made in it."""

    def __init__(self) -> None:
        self._nodes: dict[str, Node] = {}
        self._sim_time = False
        self._spinner: SingleThreadedExecutor | None = None

    # -- context ---------------------------------------------------------------
    @property
    def sim_time(self) -> bool:
        """Whether nodes made now run on ``/clock`` (``use_sim_time``)."""
        return self._sim_time and rclpy.ok()

    def init(self, *, sim_time: bool = False) -> None:
        """Initialise rclpy once; again only when the time source has to change.

        ``sim_time=True`` makes every node created afterwards start with
        ``use_sim_time`` set, so its timers run on ``/clock`` from their first tick
        (setting the parameter after a timer exists shifts the timer's phase).
        Changing the time source destroys the session's nodes.
        """
        if rclpy.ok() and sim_time == self._sim_time:
            return
        self.shutdown()
        args = ["--ros-args", "-p", "use_sim_time:=true"] if sim_time else None
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        self._sim_time = sim_time
        self._spinner = None
        _install_tracking(self)

    def shutdown(self) -> None:
        """Destroy the session's nodes and shut the context down (safe to repeat)."""
        self.reset()
        if self._spinner is not None:
            self._spinner.shutdown(timeout_sec=0)
            self._spinner = None
        rclpy.try_shutdown()
        self._sim_time = False

    # -- nodes -----------------------------------------------------------------
    def _track(self, node: Node) -> None:
        self._nodes[node.get_fully_qualified_name()] = node

    def _forget(self, node: Node) -> None:
        for name, tracked in list(self._nodes.items()):
            if tracked is node:
                del self._nodes[name]

    def _make_room(self, name: str, namespace: str | None) -> None:
        """Destroy the live node a re-run cell is about to create again."""
        fq_name = _fully_qualified(name, namespace)
        old = self._nodes.pop(fq_name, None)
        if old is not None:
            _destroy(old)

    def remove(self, node: Node) -> None:
        """Destroy ``node`` (it also leaves the session)."""
        _destroy(node)

    @property
    def nodes(self) -> list[Node]:
        """The live nodes made in this kernel since ``init``."""
        return list(self._nodes.values())

    def reset(self) -> None:
        """Destroy every node of the session."""
        for node in list(self._nodes.values()):
            _destroy(node)
        self._nodes.clear()

    # -- spinning --------------------------------------------------------------
    def _executor(self, nodes: Iterable[Node]) -> SingleThreadedExecutor:
        """The session's one executor, holding ``nodes`` for this spin.

        One executor for the whole context, not one per call: coroutines it started
        (an action server's execute callback awaiting its next step) live in its task
        list and must still be there at the next spin.
        """
        if self._spinner is None:
            self._spinner = SingleThreadedExecutor()
        # A spin nested in a callback of another spin gets an executor of its own.
        executor = SingleThreadedExecutor() if self._spinner.get_nodes() else self._spinner
        for node in nodes or self._nodes.values():
            executor.add_node(node)
        return executor

    def _release(self, executor: SingleThreadedExecutor) -> None:
        for node in list(executor.get_nodes()):
            executor.remove_node(node)
        if executor is not self._spinner:
            executor.shutdown(timeout_sec=0)

    def spin_for(self, seconds: float, *nodes: Node) -> None:
        """Spin ``nodes`` (default: all of the session's) for ``seconds`` of wall time."""
        self.spin_until(lambda: False, *nodes, timeout=seconds)

    def spin_until(self, condition: Callable[[], bool], *nodes: Node, timeout: float = 5.0) -> bool:
        """Spin until ``condition()`` is true or ``timeout`` seconds have passed.

        Returns whether the condition came true; never blocks longer than ``timeout``.
        """
        executor = self._executor(nodes)
        try:
            return _spin_executor(executor, condition, timeout)
        finally:
            self._release(executor)
            _settle_output()

    def spin_with(self, node: Node, condition: Callable[[], bool], timeout: float) -> bool:
        """Spin until ``condition()``: the whole session if ``node`` belongs to it (a
        server in the same kernel must run to answer), else ``node`` alone in its own
        context (a command-line tool's node)."""
        if any(node is tracked for tracked in self._nodes.values()):
            return self.spin_until(condition, timeout=timeout)
        executor = SingleThreadedExecutor(context=node.context)
        executor.add_node(node)
        try:
            return _spin_executor(executor, condition, timeout)
        finally:
            executor.remove_node(node)
            executor.shutdown(timeout_sec=0)

    def spin_pending(self, *nodes: Node, rounds: int = 20) -> None:
        """Run the callbacks that are ready now, without waiting for new work."""
        executor = self._executor(nodes)
        try:
            _drain(executor, rounds)
        finally:
            self._release(executor)

    # -- simulated time ----------------------------------------------------------
    def sim_clock(self) -> SimClock:
        """A fresh simulated world: no nodes, and a ``/clock`` that starts at t = 0.

        Every node of the session is destroyed, so that each node made afterwards
        starts its clock (and its timers) at zero, exactly like the clock itself.
        """
        self.init(sim_time=True)
        self.reset()
        return SimClock(self)


class SimClock:
    """Publishes ``/clock`` in lockstep: each step waits until every node has caught up.

    Timers of nodes with ``use_sim_time`` fire exactly on simulated time, so a check of
    a rate or a period is exact and takes a fraction of the wall time it simulates.
    """

    def __init__(self, session: Session) -> None:
        self._session = session
        self._node = Node("sim_clock")
        self._pub: Publisher = self._node.create_publisher(Clock, "/clock", QoSProfile(depth=10))
        self.now = 0.0

    def advance(
        self, seconds: float, *nodes: Node, step: float = 0.01, catch_up_timeout: float = 5.0
    ) -> None:
        """Move simulated time forward by ``seconds`` in steps of ``step``.

        After each step the ready callbacks of ``nodes`` (default: all of the session's)
        run before time moves on, as they would on a robot running in real time.
        """
        watched = [n for n in (nodes or self._session.nodes) if n is not self._node]
        executor = self._session._executor([*watched, self._node])
        try:
            end = self.now + seconds
            while self.now < end - 1e-12:
                self.now = min(self.now + step, end)
                self._publish_and_wait(executor, watched, catch_up_timeout)
                _drain(executor, rounds=8)
        finally:
            self._session._release(executor)

    def advance_remote(self, seconds: float, step: float = 0.05, settle: float = 0.02) -> None:
        """Advance ``/clock`` for nodes in other processes, whose clocks we cannot read.

        Each step is followed by ``settle`` seconds of wall time in which the session's
        nodes spin, so the other process can react and its messages arrive.
        """
        end = self.now + seconds
        while self.now < end - 1e-12:
            self.now = min(self.now + step, end)
            self._pub.publish(self._message())
            self._session.spin_for(settle)

    def subscriber_count(self) -> int:
        """How many time sources (in any process) listen to this clock."""
        return self._pub.get_subscription_count()

    def _message(self) -> Clock:
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = divmod(int(round(self.now * 1e9)), 1_000_000_000)
        return msg

    def _publish_and_wait(
        self, executor: SingleThreadedExecutor, nodes: list[Node], timeout: float
    ) -> None:
        target = int(round(self.now * 1e9))
        msg = self._message()
        deadline = time.monotonic() + timeout

        def caught_up() -> bool:
            return all(n.get_clock().now().nanoseconds >= target for n in nodes)

        while True:
            self._pub.publish(msg)
            if _spin_executor(executor, caught_up, timeout=0.2):
                return
            if time.monotonic() > deadline:  # republished every 0.2 s until then
                behind = [n for n in nodes if n.get_clock().now().nanoseconds < target]
                names = ", ".join(n.get_name() for n in behind)
                raise TimeoutError(
                    f"node(s) {names} did not follow /clock to t={self.now:.3f} s: "
                    "was the node created after ros.init(sim_time=True) / ros.sim_clock()?"
                )


def _spin_executor(
    executor: SingleThreadedExecutor, condition: Callable[[], bool], timeout: float
) -> bool:
    deadline = time.monotonic() + timeout
    while True:
        if condition():
            return True
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return False
        executor.spin_once(timeout_sec=min(POLL_S, remaining))


def _drain(executor: SingleThreadedExecutor, rounds: int) -> None:
    """Run what is ready now (a timer that came due, a message that arrived)."""
    for _ in range(rounds):
        executor.spin_once(timeout_sec=0.0)


def _settle_output() -> None:
    """Let a Jupyter kernel show ROS log lines in the cell that caused them.

    rcl writes log lines to file descriptor 1 from C; ipykernel forwards that file
    descriptor to the notebook from a thread. Give the thread a moment and flush, so
    the lines land in this cell's output rather than the next one's.
    """
    stdout = sys.stdout
    if hasattr(stdout, "_original_stdstream_copy"):  # ipykernel's captured stream
        time.sleep(0.05)
        stdout.flush()


def _fully_qualified(name: str, namespace: str | None) -> str:
    namespace = "/" + (namespace or "").strip("/")
    return f"{namespace.rstrip('/')}/{name}"


_tracked_session: Session | None = None


def _install_tracking(session: Session) -> None:
    """Make every node created in this process known to ``session``.

    Wraps ``Node.__init__`` and ``Node.destroy_node`` once: a node created under the
    name and namespace of a live node destroys that older node *first*, so re-running
    a cell never leaves two nodes of one name (rcl would warn, and destroying the
    older one later would unregister the newer one's ``/rosout`` publisher).
    Nodes of a context other than the default one are left alone.
    """
    global _tracked_session
    if _tracked_session is not None:
        _tracked_session = session
        return
    _tracked_session = session
    original_init = Node.__init__
    original_destroy = Node.destroy_node

    def init(self: Node, node_name: str, *args: Any, **kwargs: Any) -> None:
        tracked = _tracked_session is not None and kwargs.get("context") is None
        if tracked:
            _tracked_session._make_room(node_name, kwargs.get("namespace"))
        original_init(self, node_name, *args, **kwargs)
        if tracked:
            _tracked_session._track(self)

    def destroy_node(self: Node) -> None:
        if _tracked_session is not None:
            _tracked_session._forget(self)
        original_destroy(self)

    init.__doc__ = original_init.__doc__
    destroy_node.__doc__ = original_destroy.__doc__
    Node.__init__ = init  # type: ignore[method-assign]
    Node.destroy_node = destroy_node  # type: ignore[method-assign]


def _destroy(node: Node) -> None:
    try:
        node.destroy_node()
    except Exception:  # already destroyed, or its context is gone
        pass


#: The kernel's session.
ros = Session()
