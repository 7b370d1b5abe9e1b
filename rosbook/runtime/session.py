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

Only the notebook's session (``ros``) tracks nodes by itself: while it is initialised,
every node created in the default context joins it (``Node.__init__`` is wrapped, and
unwrapped again by ``shutdown``). A ``Session(track_nodes=False)`` knows only the nodes
given to ``add``. Library code does not reach for ``ros``: it takes the node it works
through and spins it with :func:`spin_node_until` (the node's session, or the node
alone).

Threads: the session's bookkeeping (its nodes, its executor) is guarded by a lock, so
nodes may be created and destroyed from any thread. Spinning is not shared: a node is
spun by one executor at a time; code that spins nodes in a thread of its own (the QoS
chapter's ``Spinner``) spins only nodes it was given, never ``ros.spin_*`` concurrently.
"""

from __future__ import annotations

import os
import sys
import threading
import time
import weakref
from collections.abc import Callable, Iterable
from typing import Any

import rclpy
from rclpy.action import ActionClient, ActionServer
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from rosbook.runtime.clock import CATCH_UP_TIMEOUT_S, LockstepClock, to_ns
from rosbook.runtime.executors import SingleThreadedExecutor

#: Period of the busy check inside ``spin_until`` (seconds of wall time).
POLL_S = 0.01

#: A ``spin_for`` this long on a clock that stood still says so (a wait, not a glance).
STALL_NOTICE_S = 0.5


class Session:
    """The kernel's single rclpy context and the nodes made in it."""

    def __init__(self, *, track_nodes: bool = False) -> None:
        self._nodes: dict[str, Node] = {}
        self._sim_time = False
        self._spinner: SingleThreadedExecutor | None = None
        self._track_nodes = track_nodes
        self._lock = threading.RLock()
        self._hold = False
        self._keeper: Node | None = None

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
        with self._lock:
            if rclpy.ok() and sim_time == self._sim_time:
                return
            self.shutdown()
            args = ["--ros-args", "-p", "use_sim_time:=true"] if sim_time else None
            rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
            self._sim_time = sim_time
            self._spinner = None
            if self._track_nodes:
                _install_tracking(self)
            self._keep_participant()

    def hold_participant(self, hold: bool = True) -> None:
        """Keep this process's DDS participant from now to ``shutdown`` (``hold=False``:
        no longer; it then goes with the last node, as before).

        rmw_fastrtps_cpp destroys a context's participant with its last node, and the
        next node makes a new one, which every other process has to discover again
        (0.1-0.3 s on loopback) before a single endpoint of the new node can match,
        where a new node of a known participant is seen in milliseconds. A process
        that makes and destroys nodes check after check (the grader's judge, the
        agent in a student's kernel) keeps one hidden node (``_rosbook_participant_
        <pid>``: ``ros2 node list`` leaves hidden names out, as upstream's does) for
        the participant's sake: no endpoint of its own but rclpy's
        ``/parameter_events`` publisher, no log publisher, no parameter services;
        ``reset`` and ``nodes`` leave it out.
        """
        with self._lock:
            self._hold = hold
            if hold:
                self._keep_participant()
            else:
                self._drop_keeper()

    @property
    def participant_keeper(self) -> Node | None:
        """The hidden node that holds this process's participant (``hold_participant``),
        while it is held."""
        return self._keeper

    def _keep_participant(self) -> None:
        if not self._hold or not rclpy.ok():
            return
        if self._keeper is not None and self._keeper.context.ok():
            return
        # An explicit context: never one of the session's nodes (reset keeps it).
        self._keeper = Node(
            f"_rosbook_participant_{os.getpid()}",
            context=rclpy.get_default_context(),
            start_parameter_services=False,
            enable_rosout=False,
        )

    def _drop_keeper(self) -> None:
        if self._keeper is not None:
            _destroy(self._keeper)
            self._keeper = None

    def shutdown(self) -> None:
        """Destroy the session's nodes and shut the context down (safe to repeat).

        Node tracking ends with it: ``Node`` is rclpy's own again until the next ``init``.
        """
        with self._lock:
            self.reset()
            _uninstall_tracking(self)
            if self._spinner is not None:
                self._spinner.shutdown(timeout_sec=0)
                self._spinner = None
            self._drop_keeper()
            rclpy.try_shutdown()
            self._sim_time = False

    # -- nodes -----------------------------------------------------------------
    def add(self, node: Node) -> Node:
        """Make ``node`` one of the session's: spun by ``spin_*`` without naming it,
        destroyed by ``reset``. A live node of the same name is destroyed first."""
        with self._lock:
            old = self._nodes.get(node.get_fully_qualified_name())
            if old is not None and old is not node:
                self._forget(old)
                _destroy(old)
            self._track(node)
        return node

    def _track(self, node: Node) -> None:
        with self._lock:
            self._nodes[node.get_fully_qualified_name()] = node
            _owners[node] = self

    def _forget(self, node: Node) -> None:
        with self._lock:
            for name, tracked in list(self._nodes.items()):
                if tracked is node:
                    del self._nodes[name]
            if _owners.get(node) is self:
                del _owners[node]

    def _make_room(self, name: str, namespace: str | None) -> None:
        """Destroy the live node a re-run cell is about to create again."""
        fq_name = _fully_qualified(name, namespace)
        with self._lock:
            old = self._nodes.pop(fq_name, None)
        if old is not None:
            _destroy(old)

    def remove(self, node: Node) -> None:
        """Destroy ``node`` (it also leaves the session)."""
        self._forget(node)
        _destroy(node)

    @property
    def nodes(self) -> list[Node]:
        """The live nodes made in this kernel since ``init``."""
        with self._lock:
            return list(self._nodes.values())

    def owns(self, node: Node) -> bool:
        """Whether ``node`` is one of the session's."""
        return _owners.get(node) is self

    def reset(self) -> None:
        """Destroy every node of the session."""
        with self._lock:
            nodes = list(self._nodes.values())
            self._nodes.clear()
        for node in nodes:
            self._forget(node)
            _destroy(node)

    # -- spinning --------------------------------------------------------------
    def _executor(self, nodes: Iterable[Node]) -> SingleThreadedExecutor:
        """The session's one executor, holding ``nodes`` for this spin.

        One executor for the whole context, not one per call: coroutines it started
        (an action server's execute callback awaiting its next step) live in its task
        list and must still be there at the next spin.
        """
        with self._lock:
            if self._spinner is None:
                self._spinner = SingleThreadedExecutor()
            # A spin nested in a callback of another spin (or running in another
            # thread) gets an executor of its own.
            executor = SingleThreadedExecutor() if self._spinner.get_nodes() else self._spinner
            for node in nodes or list(self._nodes.values()):
                executor.add_node(node)
            return executor

    def _release(self, executor: SingleThreadedExecutor) -> None:
        with self._lock:
            for node in list(executor.get_nodes()):
                executor.remove_node(node)
            if executor is not self._spinner:
                executor.shutdown(timeout_sec=0)

    def spin_for(self, seconds: float, *nodes: Node) -> None:
        """Spin ``nodes`` (default: all of the session's) for ``seconds`` of wall time.

        A node on simulated time whose clock did not move meanwhile (nothing advanced
        ``/clock``) cannot run its timers; the spin says so instead of staying silent.
        """
        waiting = [
            n for n in nodes or self.nodes if list(n.timers) and n.get_clock().ros_time_is_active
        ]
        before = [n.get_clock().now().nanoseconds for n in waiting]
        self.spin_until(lambda: False, *nodes, timeout=seconds)
        stalled = [
            n.get_name()
            for n, t in zip(waiting, before)
            if seconds >= STALL_NOTICE_S and n.get_clock().now().nanoseconds == t
        ]
        if stalled:
            print(
                f"ros.spin_for: the timers of {', '.join(stalled)} did not fire: "
                "these nodes run on simulated time and nothing advanced /clock "
                f"during these {seconds:g} s. Run ros.init() to go back to wall time, "
                "or advance the clock: clock = ros.sim_clock(); ...; clock.advance(2.0)",
                flush=True,
            )

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
    The stepping itself is :class:`rosbook.runtime.clock.LockstepClock`, shared with the QoS runs
    and the simulator.
    """

    def __init__(self, session: Session) -> None:
        self._session = session
        # Like every node of a sim-time session it also listens to /clock (checks count on
        # that: one /clock subscription per node of the session).
        self._node = Node("sim_clock")
        self.clock = LockstepClock(self._node)

    @property
    def now(self) -> float:
        """Simulated seconds since the world started."""
        return self.clock.now

    def advance(
        self,
        seconds: float,
        *nodes: Node,
        step: float = 0.01,
        catch_up_timeout: float = CATCH_UP_TIMEOUT_S,
    ) -> None:
        """Move simulated time forward by ``seconds`` in steps of ``step``.

        After each step the ready callbacks of ``nodes`` (default: all of the session's)
        run before time moves on, as they would on a robot running in real time.
        """
        watched = [n for n in (nodes or self._session.nodes) if n is not self._node]
        executor = self._session._executor(watched)

        def spin(timeout: float) -> None:
            executor.spin_once(timeout_sec=timeout)

        try:
            end = self.clock.now_ns + to_ns(seconds)
            while self.clock.now_ns < end:
                self.clock.set(
                    min(self.clock.now_ns + to_ns(step), end),
                    watched,
                    spin=spin,
                    timeout=catch_up_timeout,
                    hint=": was the node created after ros.init(sim_time=True) / ros.sim_clock()?",
                )
                _drain(executor, rounds=8)
        finally:
            self._session._release(executor)

    def advance_remote(self, seconds: float, step: float = 0.05, settle: float = 0.02) -> None:
        """Advance ``/clock`` for nodes in other processes, whose clocks we cannot read.

        Each step is followed by ``settle`` seconds of wall time in which the session's
        nodes spin, so the other process can react and its messages arrive.
        """
        end = self.clock.now_ns + to_ns(seconds)
        while self.clock.now_ns < end:
            self.clock.set(min(self.clock.now_ns + to_ns(step), end))
            self._session.spin_for(settle)

    def subscriber_count(self) -> int:
        """How many time sources (in any process) listen to this clock."""
        return self.clock.subscriber_count()


def spin_node_until(node: Node, condition: Callable[[], bool], timeout: float) -> bool:
    """Spin until ``condition()`` holds or ``timeout`` passes; whether it came true.

    What spins is what ``node`` belongs to: its whole session if it is a session's node
    (a server in the same kernel must run to answer), else ``node`` alone, in its own
    context (a command-line tool's node, a check's private node).
    """
    session = _owners.get(node)
    if session is not None:
        return session.spin_until(condition, timeout=timeout)
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    try:
        return _spin_executor(executor, condition, timeout)
    finally:
        executor.remove_node(node)
        executor.shutdown(timeout_sec=0)


def _spin_executor(
    executor: SingleThreadedExecutor, condition: Callable[[], bool], timeout: float
) -> bool:
    return spin_while_waiting(lambda s: executor.spin_once(timeout_sec=s), condition, timeout)


def spin_while_waiting(
    spin: Callable[[float], None], condition: Callable[[], bool], timeout: float
) -> bool:
    """Call ``spin(seconds)`` (for at most ``POLL_S`` s each) until ``condition()`` holds
    or ``timeout`` s have passed; whether it holds."""
    deadline = time.monotonic() + timeout
    while True:
        if condition():
            return True
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return False
        spin(min(POLL_S, remaining))


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


#: The session each tracked node belongs to (weak: a dropped node leaves by itself).
_owners: weakref.WeakKeyDictionary[Node, Session] = weakref.WeakKeyDictionary()

#: The session that ``Node.__init__`` currently reports to, and rclpy's own methods.
_tracked_session: Session | None = None
_original_node_methods: tuple[Any, Any] | None = None


def _install_tracking(session: Session) -> None:
    """Make every node created in the default context known to ``session``.

    Wraps ``Node.__init__`` and ``Node.destroy_node`` (until ``_uninstall_tracking``): a
    node created under the name and namespace of a live node destroys that older node
    *first*, so re-running a cell never leaves two nodes of one name (rcl would warn,
    and destroying the older one later would unregister the newer one's ``/rosout``
    publisher). Nodes of a context other than the default one are left alone.
    """
    global _tracked_session, _original_node_methods
    _tracked_session = session
    if _original_node_methods is not None:
        return
    original_init = Node.__init__
    original_destroy = Node.destroy_node
    _original_node_methods = (original_init, original_destroy)

    def init(self: Node, node_name: str, *args: Any, **kwargs: Any) -> None:
        owner = _tracked_session
        tracked = owner is not None and kwargs.get("context") is None
        if tracked:
            owner._make_room(node_name, kwargs.get("namespace"))
        original_init(self, node_name, *args, **kwargs)
        if tracked:
            owner._track(self)

    def destroy_node(self: Node) -> None:
        owner = _owners.get(self)
        if owner is not None:
            owner._forget(self)
        original_destroy(self)

    init.__doc__ = original_init.__doc__
    destroy_node.__doc__ = original_destroy.__doc__
    Node.__init__ = init  # type: ignore[method-assign]
    Node.destroy_node = destroy_node  # type: ignore[method-assign]


def _uninstall_tracking(session: Session) -> None:
    """Give ``Node`` back rclpy's own ``__init__`` and ``destroy_node``."""
    global _tracked_session, _original_node_methods
    if _tracked_session is not session or _original_node_methods is None:
        return
    Node.__init__, Node.destroy_node = _original_node_methods  # type: ignore[method-assign]
    _tracked_session = None
    _original_node_methods = None


def _destroy(node: Node) -> None:
    """Destroy ``node`` with its action servers and clients, which ``destroy_node`` leaves
    alive: a re-run cell's old server would stay on the graph, a second server."""
    for waitable in list(node.waitables):
        if isinstance(waitable, (ActionServer, ActionClient)):
            try:
                waitable.destroy()
            except Exception:  # already destroyed
                pass
    try:
        node.destroy_node()
    except Exception:  # already destroyed, or its context is gone
        pass


#: The kernel's session: the notebook's, the only one that tracks nodes by itself.
ros = Session(track_nodes=True)


def notebook_session(session: Session | None = None) -> Session:
    """``session``, or by default the notebook's (``ros``): the one default that the
    functions a notebook cell calls (``graph.echo``, ``ros2``, ``Simulation``) use."""
    return ros if session is None else session
