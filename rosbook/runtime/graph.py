"""The running ROS graph, read through rclpy: what ``ros2 node|topic|interface`` show.

Every function takes an *observer* node, through which DDS is asked what it has
discovered. In a notebook that is any node of the ``ros`` session (or none: a hidden
observer node is made for you), and waiting for messages then spins every node of the
session, so the talker in the next cell keeps publishing while ``echo`` listens. The
``ros2`` command of this project passes its own hidden node in a private context.

::

    from rosbook.runtime import graph

    graph.node_names()                       # ros2 node list
    graph.topic_names_and_types()            # ros2 topic list -t
    print(graph.topic_info('/chatter').format(verbose=True))   # ros2 topic info -v
    graph.echo('/chatter', count=3)          # ros2 topic echo, three messages (as messages)
    graph.hz('/chatter', duration=2.0)       # ros2 topic hz
    print(graph.node_info('/talker').format())                 # ros2 node info
    print(interface_show('geometry_msgs/msg/Pose'))            # ros2 interface show

Failures a user can cause (an unknown topic, a topic nobody publishes, an unknown node
or interface) raise ``GraphError`` with a one-line message.
"""

from __future__ import annotations

import math
import os
import time
import weakref
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.topic_endpoint_info import TopicEndpointInfo

from rosbook.runtime.interfaces import InterfaceError, message_class
from rosbook.runtime.interfaces import show as interface_show
from rosbook.runtime.isolation import FASTDDS_PROFILE
from rosbook.runtime.session import Session, notebook_session, spin_node_until

__all__ = [
    "GraphError",
    "HzMonitor",
    "absolute_name",
    "NodeInfo",
    "Rate",
    "TopicInfo",
    "discovering_since",
    "echo",
    "hz",
    "interface_show",
    "is_hidden",
    "keep_watching",
    "lookup",
    "node_info",
    "node_names",
    "observer",
    "ANNOUNCE_PERIOD_S",
    "settle",
    "snapshot",
    "topic_info",
    "topic_names_and_types",
    "wait_for",
]

NamesAndTypes = list[tuple[str, list[str]]]

#: Name of the hidden node that observes the graph for a notebook.
OBSERVER_NAME = "_rosbook_graph"


class GraphError(LookupError):
    """Something asked of the graph that is not on it (a one-line message)."""


def absolute_name(name: str) -> str:
    """A node, topic or namespace name made absolute: ``chatter`` -> ``/chatter``."""
    return "/" + name.lstrip("/")


def is_hidden(name: str) -> bool:
    """Whether a node or topic name is hidden: one of its tokens starts with ``_``."""
    return any(token.startswith("_") for token in name.split("/") if token)


def observer(node: Node | None = None, session: Session | None = None) -> Node:
    """``node``, or the hidden observer node of ``session`` (made once; by default of
    the notebook's session, ``rosbook.ros``, for calls from a notebook cell)."""
    if node is not None:
        return node
    session = notebook_session(session)
    session.init()
    for existing in session.nodes:
        if existing.get_name() == OBSERVER_NAME:
            return existing
    return session.add(Node(OBSERVER_NAME, start_parameter_services=False))


def _spin_until(node: Node, condition: Callable[[], bool], timeout: float) -> bool:
    """Spin until ``condition()``: ``node``'s whole session, or ``node`` alone."""
    return spin_node_until(node, condition, timeout)


def wait_for(
    condition: Callable[[Node], bool], node: Node | None = None, timeout: float = 5.0
) -> bool:
    """Spin until ``condition(observer)`` holds, e.g. a node started in another process
    has been discovered: ``wait_for(lambda g: '/talker' in node_names(g))``."""
    watcher = observer(node)
    return _spin_until(watcher, lambda: condition(watcher), timeout)


#: The node name rmw reports for an endpoint whose participant's node list has not
#: arrived yet (discovery of endpoints and of node names run separately).
UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"


def snapshot(node: Node | None = None) -> tuple[object, ...]:
    """What discovery has found so far: nodes, topics with types, each topic's endpoints
    by node, services with types."""
    watcher = observer(node)
    topics = sorted((n, tuple(t)) for n, t in watcher.get_topic_names_and_types())
    endpoints = tuple(
        tuple(
            sorted(
                (i.node_namespace, i.node_name, i.endpoint_type.name)
                for i in [
                    *watcher.get_publishers_info_by_topic(n),
                    *watcher.get_subscriptions_info_by_topic(n),
                ]
            )
        )
        for n, _ in topics
    )
    services = sorted((n, tuple(t)) for n, t in watcher.get_service_names_and_types())
    nodes = tuple(sorted(watcher.get_fully_qualified_node_names()))
    return (nodes, tuple(topics), endpoints, tuple(services))


def _complete(shot: tuple[object, ...]) -> bool:
    """Whether every endpoint in ``snapshot`` output belongs to a known node."""
    endpoints: tuple[tuple[tuple[str, str, str], ...], ...] = shot[2]  # type: ignore[assignment]
    return all(name != UNKNOWN_NODE for topic in endpoints for _, name, _ in topic)


#: Period of participant announcements (seconds): Fast DDS's default is 3 s; this
#: project's isolated runs use 0.25 s (rosbook/runtime/fastdds_local.xml). A process that just
#: started learns of the older ones when they next announce themselves, so it may need
#: this long to see the whole graph (the real CLI keeps a daemon for this).
ANNOUNCE_PERIOD_S = (
    0.25 if os.environ.get("FASTRTPS_DEFAULT_PROFILES_FILE") == str(FASTDDS_PROFILE) else 3.0
)
#: How long ``settle`` waits for a first visible node before it trusts an empty graph:
#: a new participant usually hears the others within 0.1-0.6 s on loopback, but a
#: command and the daemon it started both heard nothing of a live kernel for 1.5 s once
#: (a quiet machine, the JupyterLab test).
FIRST_NODE_WAIT_S = ANNOUNCE_PERIOD_S + 2.0
#: How long discovery must have found nothing new for the graph to count as settled
#: (at least: see ``settle``).
QUIET_S = 0.25
#: Longest ``settle`` and ``lookup`` wait: a guard against a graph that never settles
#: (one that keeps changing), not a verdict; they answer with what they found by then.
SETTLE_TIMEOUT_S = 20.0


#: When each observer's participant started discovering (``discovering_since``).
_SINCE: weakref.WeakKeyDictionary[Node, float] = weakref.WeakKeyDictionary()


#: When each such observer was made (``discovering_since`` is called right after).
_MADE: weakref.WeakKeyDictionary[Node, float] = weakref.WeakKeyDictionary()


def discovering_since(node: Node, started: float) -> None:
    """Record that ``node``'s participant began discovery at ``started``
    (``time.monotonic()`` before ``rclpy.init``): ``settle`` then counts its waits
    from there, not from its own call, so a command that just started waits less.
    Call it right after making ``node``: how long that took tells how busy the machine
    is (see ``settle``)."""
    _SINCE[node] = started
    _MADE[node] = time.monotonic()


class _Watch:
    """What an observer's discovery has shown: the last snapshot, when it last changed,
    how long the first other node took to show up, whether it ever settled."""

    def __init__(self, shot: tuple[object, ...], t: float) -> None:
        self.last, self.changed = shot, t
        self.first_seen: float | None = None
        self.settled_once = False

    def settled(
        self,
        shot: tuple[object, ...],
        *,
        start: float,
        at_least: float,
        quiet: float,
        made: float,
    ) -> bool:
        """Whether discovery has settled now (``settle``), ``shot`` being the observer's
        ``snapshot`` now; ``start``: when the observer began discovering; ``made``: when
        it was made."""
        t = time.monotonic()
        if shot != self.last:
            self.last, self.changed = shot, t
        quiet_for = t - self.changed
        if not _others_seen(self.last) and not self.settled_once:
            # an empty graph: trusted once the observer, made, has waited for the others'
            # answers as long as its own making took (a starved machine answers late)
            waited = max(FIRST_NODE_WAIT_S, at_least, made - start)
            done = t - made >= waited and quiet_for >= quiet
        else:
            if self.first_seen is None:  # how long the others took to answer us
                self.first_seen = 0.0 if self.settled_once else t - start  # (not a newcomer)
            needed = max(quiet, self.first_seen)
            done = t - start >= at_least and quiet_for >= needed and _complete(self.last)
        self.settled_once |= done
        return done


def _others_seen(shot: tuple[object, ...]) -> bool:
    """Whether ``snapshot`` output shows a node that makes the graph more than empty: a
    visible one, or one whose endpoints came and whose name did not yet (names can come
    seconds later). Hidden nodes alone do not: a ``ros2`` command's daemon, started
    with it, is seen first and says nothing of the others."""
    nodes: tuple[str, ...] = shot[0]  # type: ignore[assignment]
    return any(not is_hidden(n) for n in nodes) or not _complete(shot)


#: Observers whose discovery is followed across calls (``keep_watching``).
_WATCHES: weakref.WeakKeyDictionary[Node, _Watch] = weakref.WeakKeyDictionary()


def keep_watching(node: Node) -> Callable[[], bool]:
    """Follow ``node``'s discovery across ``settle`` calls, for a long-lived observer (the
    ``ros2`` daemon), from now on: once settled, a later ``settle`` waits only until
    nothing changed for as long as it took then, counted from the last change seen by any
    call or by the returned function, which looks at the graph now and says whether it
    has settled (call it while idle)."""
    called = time.monotonic()
    start, made = _SINCE.get(node, called), _MADE.get(node, called)
    watch = _WATCHES.setdefault(node, _Watch(snapshot(node), called))
    return lambda: watch.settled(
        snapshot(node), start=start, at_least=ANNOUNCE_PERIOD_S, quiet=QUIET_S, made=made
    )


def settle(
    node: Node | None = None,
    *,
    at_least: float = 0.0,
    quiet: float = QUIET_S,
    timeout: float = SETTLE_TIMEOUT_S,
    until: Callable[[], bool] | None = None,
) -> bool:
    """Spin until discovery has settled, or ``until()`` holds; False on ``timeout``.

    Settled means: nothing new for ``quiet`` s (and ``at_least`` s passed), and every
    endpoint's node known. Discovery is not instantaneous: a participant first learns
    that another exists, then its endpoints, and the names of its nodes separately (an
    endpoint's node is ``_NODE_NAME_UNKNOWN_`` until then). A busy machine answers late,
    so the quiet period grows with how long the first node took to show up, counted
    from the observer's start (its own start-up too: a machine that starved it will
    deliver the others' endpoints in slow pieces as well): the graph settles fast where
    answers come fast and waits longer where they come late.
    While no one else is known (no visible node, no endpoint whose node is not named
    yet), "nothing new" proves little (the first announcements may still be under way;
    a node's endpoints can come seconds before its name), so an empty graph is only trusted
    ``FIRST_NODE_WAIT_S`` after the observer was made, and no sooner than its making
    took (a command starved while it started will hear the others late as well).
    ``at_least`` counts from ``discovering_since`` when the observer's start was
    recorded (a command's own start-up counts), else from this call. An observer that
    ``keep_watching`` follows counts its quiet period from the last change it saw, and
    the first node's delay from when it began.
    """
    watcher = observer(node)
    called = time.monotonic()
    start, made = _SINCE.get(watcher, called), _MADE.get(watcher, called)
    watch = _WATCHES.get(watcher) or _Watch(snapshot(watcher), called)

    def settled() -> bool:
        if until is not None and until():
            return True
        return watch.settled(
            snapshot(watcher), start=start, at_least=at_least, quiet=quiet, made=made
        )

    return _spin_until(watcher, settled, timeout)


def lookup(
    found: Callable[[Node], bool], node: Node | None = None, *, timeout: float = SETTLE_TIMEOUT_S
) -> bool:
    """Whether ``found(observer)`` holds: True as soon as discovery shows it, False once
    the graph has settled without it (``settle``, after one announcement period at least,
    as a listing waits: an older participant may only be heard when it next announces
    itself), e.g. ``ros2 topic info`` asking for
    ``lookup(lambda g: '/chatter' in dict(g.get_topic_names_and_types()))``."""
    watcher = observer(node)
    settle(watcher, at_least=ANNOUNCE_PERIOD_S, timeout=timeout, until=lambda: found(watcher))
    return found(watcher)


# -- nodes -------------------------------------------------------------------------
def node_names(node: Node | None = None, *, include_hidden: bool = False) -> list[str]:
    """Fully qualified names of the nodes on the graph, sorted (``ros2 node list``)."""
    names = set(observer(node).get_fully_qualified_node_names())
    return sorted(n for n in names if include_hidden or not is_hidden(n))


def _split_node_name(fq_name: str) -> tuple[str, str]:
    fq_name = "/" + fq_name.lstrip("/")
    namespace, _, name = fq_name.rpartition("/")
    return name, namespace or "/"


@dataclass(frozen=True)
class NodeInfo:
    """A node's endpoints, each a list of ``(name, [types])`` (``ros2 node info``)."""

    name: str
    subscribers: NamesAndTypes
    publishers: NamesAndTypes
    service_servers: NamesAndTypes
    service_clients: NamesAndTypes
    action_servers: NamesAndTypes
    action_clients: NamesAndTypes

    def format(self) -> str:
        """The text ``ros2 node info NAME`` prints."""
        lines = [self.name]
        for title, entries in (
            ("Subscribers", self.subscribers),
            ("Publishers", self.publishers),
            ("Service Servers", self.service_servers),
            ("Service Clients", self.service_clients),
            ("Action Servers", self.action_servers),
            ("Action Clients", self.action_clients),
        ):
            lines.append(f"  {title}:")
            lines.extend(f"    {name}: {', '.join(types)}" for name, types in entries)
            if not entries:
                lines.append("")
        return "\n".join(lines)


def node_info(
    fq_name: str, node: Node | None = None, *, include_hidden: bool = False, wait: float = 0.0
) -> NodeInfo:
    """What ``ros2 node info FQ_NAME`` shows; ``GraphError`` for a node not on the graph.

    ``wait``: seconds to wait for the node to be discovered (it may have just started).
    """
    watcher = observer(node)
    name, namespace = _split_node_name(fq_name)
    full = f"{namespace.rstrip('/')}/{name}"

    def found() -> bool:
        return full in set(watcher.get_fully_qualified_node_names())

    if not found() and not (wait > 0 and _spin_until(watcher, found, wait)):
        raise GraphError(f"node '{full}' is not on the graph (see `ros2 node list`)")

    # rclpy.action imports numpy (for goal UUIDs): only here, so that a cold
    # ``ros2 node list`` does not pay for it.
    from rclpy.action import get_action_client_names_and_types_by_node as action_clients
    from rclpy.action import get_action_server_names_and_types_by_node as action_servers

    def visible(entries: NamesAndTypes) -> NamesAndTypes:
        return sorted((n, list(t)) for n, t in entries if include_hidden or not is_hidden(n))

    return NodeInfo(
        name=full,
        subscribers=visible(watcher.get_subscriber_names_and_types_by_node(name, namespace)),
        publishers=visible(watcher.get_publisher_names_and_types_by_node(name, namespace)),
        service_servers=visible(watcher.get_service_names_and_types_by_node(name, namespace)),
        service_clients=visible(watcher.get_client_names_and_types_by_node(name, namespace)),
        action_servers=visible(action_servers(watcher, name, namespace)),
        action_clients=visible(action_clients(watcher, name, namespace)),
    )


# -- topics ------------------------------------------------------------------------
def topic_names_and_types(
    node: Node | None = None, *, include_hidden: bool = False
) -> NamesAndTypes:
    """Topics on the graph with their types, sorted (``ros2 topic list -t``)."""
    entries = observer(node).get_topic_names_and_types()
    return sorted((n, list(t)) for n, t in entries if include_hidden or not is_hidden(n))


@dataclass(frozen=True)
class TopicInfo:
    """A topic's types and endpoints; each endpoint carries its QoS (``ros2 topic info``)."""

    name: str
    types: list[str]
    publishers: list[TopicEndpointInfo] = field(default_factory=list)
    subscriptions: list[TopicEndpointInfo] = field(default_factory=list)

    def format(self, verbose: bool = False) -> str:
        """The text ``ros2 topic info [-v] NAME`` prints."""
        lines = [f"Type: {', '.join(self.types)}"]
        if verbose:
            lines.append("")
        lines.append(f"Publisher count: {len(self.publishers)}")
        if verbose:
            lines.append("")
            for info in self.publishers:
                lines += [str(info), ""]
        lines.append(f"Subscription count: {len(self.subscriptions)}")
        if verbose:
            lines.append("")
            for info in self.subscriptions:
                lines += [str(info), ""]
        return "\n".join(lines).rstrip("\n")


def topic_info(topic: str, node: Node | None = None, *, wait: float = 0.0) -> TopicInfo:
    """Types and endpoints of ``topic``; ``GraphError`` when it is not on the graph.

    ``wait``: seconds to wait for the topic to be discovered.
    """
    watcher = observer(node)
    topic = absolute_name(topic)

    def types_now() -> list[str]:
        return list(dict(watcher.get_topic_names_and_types()).get(topic, []))

    if wait > 0 and not types_now():
        _spin_until(watcher, lambda: bool(types_now()), wait)
    types = types_now()
    if not types:
        raise GraphError(f"topic '{topic}' does not exist on the graph (see `ros2 topic list`)")
    by_name = lambda infos: sorted(infos, key=lambda i: (i.node_namespace, i.node_name))  # noqa: E731
    return TopicInfo(
        name=topic,
        types=list(types),
        publishers=by_name(watcher.get_publishers_info_by_topic(topic)),
        subscriptions=by_name(watcher.get_subscriptions_info_by_topic(topic)),
    )


def qos_summary(info: TopicEndpointInfo) -> str:
    """One line of an endpoint's main QoS policies, e.g. ``RELIABLE, VOLATILE, KEEP_LAST(10)``."""
    qos = info.qos_profile
    history = qos.history.name + (f"({qos.depth})" if qos.history.name == "KEEP_LAST" else "")
    return f"{qos.reliability.name}, {qos.durability.name}, {history}"


def qos_for_publishers(publishers: list[TopicEndpointInfo], depth: int = 10) -> QoSProfile:
    """A subscription QoS that matches every publisher (as ``ros2 topic echo`` picks it).

    Reliable only if every publisher is reliable; transient-local only if every
    publisher keeps its last messages for late joiners.
    """
    qos = QoSProfile(depth=depth)
    reliable = all(p.qos_profile.reliability == ReliabilityPolicy.RELIABLE for p in publishers)
    latched = all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers)
    qos.reliability = ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT
    qos.durability = DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE
    return qos


def _published(topic: str, watcher: Node, wait: float) -> tuple[TopicInfo, type]:
    """The info and message class of a topic that has at least one publisher."""
    if wait > 0:
        name = absolute_name(topic)
        _spin_until(watcher, lambda: watcher.count_publishers(name) > 0, wait)
    info = topic_info(topic, watcher)
    if not info.publishers:
        raise GraphError(
            f"topic '{info.name}' has no publisher ({len(info.subscriptions)} subscription(s) "
            "only): nothing to receive"
        )
    try:
        return info, message_class(info.types[0])
    except InterfaceError as error:
        raise GraphError(str(error)) from None


def echo(
    topic: str,
    count: float = 1,
    node: Node | None = None,
    *,
    timeout: float = 5.0,
    on_message: Callable[[Any], None] | None = None,
    wait: float = 0.0,
) -> list[Any]:
    """Receive ``count`` messages on ``topic`` (``ros2 topic echo`` until ``count``; inf: no limit).

    Returns the messages received within ``timeout`` seconds (fewer if the publisher
    was slower); ``on_message`` is called with each as it arrives. ``wait``: seconds
    to wait for a publisher to be discovered first.
    """
    watcher = observer(node)
    info, msg_type = _published(topic, watcher, wait)
    received: list[Any] = []

    def store(msg: Any) -> None:
        if len(received) < count:
            received.append(msg)
            if on_message is not None:
                on_message(msg)

    subscription = watcher.create_subscription(
        msg_type, info.name, store, qos_for_publishers(info.publishers)
    )
    try:
        _spin_until(watcher, lambda: len(received) >= count, timeout)
    finally:
        watcher.destroy_subscription(subscription)
    return received


# -- rates -------------------------------------------------------------------------
@dataclass(frozen=True)
class Rate:
    """Statistics of the intervals between messages (``ros2 topic hz``)."""

    rate: float
    min: float
    max: float
    std_dev: float
    window: int

    def format(self) -> str:
        """The two lines ``ros2 topic hz`` prints each second."""
        return (
            f"average rate: {self.rate:.3f}\n"
            f"\tmin: {self.min:.3f}s max: {self.max:.3f}s std dev: {self.std_dev:.5f}s "
            f"window: {self.window}"
        )


class HzMonitor:
    """Stamps each message of a topic with the observer's clock on arrival.

    Timestamps come from the node's clock, so an observer with ``use_sim_time``
    measures simulated time, like ``ros2 topic hz`` does (``wall_time``: the wall
    clock, its ``--wall-time``); ``keep``: only messages it accepts count (its
    ``--filter``). It only records: whoever spins the observer (``hz``, the session,
    a ``SimClock``) drives it.
    """

    def __init__(
        self,
        topic: str,
        node: Node | None = None,
        *,
        window: int = 10_000,
        wait: float = 0.0,
        wall_time: bool = False,
        keep: Callable[[Any], bool] | None = None,
    ) -> None:
        self.node = observer(node)
        info, msg_type = _published(topic, self.node, wait)
        self.topic = info.name
        self.times: deque[int] = deque(maxlen=window + 1)
        self._wall_time, self._keep = wall_time, keep
        self._subscription = self.node.create_subscription(
            msg_type,
            info.name,
            self._stamp,
            qos_for_publishers(info.publishers),
            raw=keep is None,  # a filter reads the message; counting needs only its arrival
        )

    def _stamp(self, msg: Any) -> None:
        if self._keep is not None and not self._keep(msg):
            return
        now = time.time_ns() if self._wall_time else self.node.get_clock().now().nanoseconds
        self.times.append(now)

    @property
    def count(self) -> int:
        """Messages received (within the window)."""
        return len(self.times)

    def rate(self) -> Rate | None:
        """The statistics so far; ``None`` before two messages arrived."""
        if len(self.times) < 2:
            return None
        stamps = list(self.times)
        intervals = [(b - a) * 1e-9 for a, b in zip(stamps, stamps[1:])]
        mean = sum(intervals) / len(intervals)
        variance = sum((d - mean) ** 2 for d in intervals) / len(intervals)
        return Rate(
            rate=1.0 / mean if mean > 0 else math.inf,
            min=min(intervals),
            max=max(intervals),
            std_dev=math.sqrt(variance),
            window=len(stamps),
        )

    def close(self) -> None:
        """Remove the monitor's subscription."""
        self.node.destroy_subscription(self._subscription)


def hz(
    topic: str,
    node: Node | None = None,
    *,
    duration: float = 2.0,
    window: int = 10_000,
    wait: float = 0.0,
) -> Rate:
    """Measure the rate of ``topic`` for ``duration`` seconds of wall time.

    ``GraphError`` when fewer than two messages arrived.
    """
    monitor = HzMonitor(topic, node, window=window, wait=wait)
    try:
        _spin_until(monitor.node, lambda: False, duration)
        rate = monitor.rate()
    finally:
        monitor.close()
    if rate is None:
        raise GraphError(
            f"topic '{monitor.topic}': {monitor.count} message(s) in {duration:g} s, "
            "too few to measure a rate"
        )
    return rate
