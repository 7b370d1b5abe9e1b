"""rosbag2 bags: record live topics, read them back, play them, as ``ros2 bag`` does.

A bag is a folder with ``metadata.yaml`` and one storage file: ``.mcap`` (Jazzy's
default) or ``.db3`` (sqlite3). The folders are written and read by the ``rosbags``
library, so a full ROS 2 install (``ros2 bag info/play``), Foxglove or any MCAP reader
opens them, and this module plays bags that those tools wrote.

Messages are stored as CDR, the bytes DDS carries: :class:`Recorder` subscribes with
``raw=True`` and stores what arrives; :class:`BagWriter` serializes message objects with
``rclpy.serialization``, and :func:`read_messages` deserializes into the live message
classes. Each topic's definition (``ros2msg`` text and type hash, which MCAP readers
need) comes from the ``.msg`` files installed with the live types.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import yaml
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import (
    DurabilityPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.subscription import Subscription
from rclpy.topic_endpoint_info import TopicEndpointInfo
from rosbags.interfaces import (
    Connection,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import Reader, ReaderError, StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from rosbook.runtime import graph
from rosbook.runtime.executors import SingleThreadedExecutor
from rosbook.runtime.interfaces import InterfaceError, definition, fields, message_class

#: ``ros2 bag record -s``: the storage plugins, Jazzy's default first.
STORAGES = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}
DEFAULT_STORAGE = "mcap"
#: Messages a recorder's subscription queues before its callback takes them.
RECORD_DEPTH = 100

_STORE: Typestore | None = None
_NESTED = re.compile(r"([A-Za-z]\w*)/(?:msg/)?([A-Za-z]\w*)")


class BagError(LookupError):
    """A bag that cannot be written or read as asked (message for the user)."""


def default_path() -> Path:
    """``rosbag2_2026_11_22-21_10_26``: upstream's name for a bag without ``-o``."""
    return Path(datetime.now().strftime("rosbag2_%Y_%m_%d-%H_%M_%S"))


# -- types -------------------------------------------------------------------------
def typestore(type_names: Iterable[str] = ()) -> Typestore:
    """rosbags' type store, with ``type_names`` (and the types they nest) registered
    from the installed ``.msg`` files when Jazzy's built-in store lacks them."""
    global _STORE
    if _STORE is None:
        _STORE = get_typestore(Stores.ROS2_JAZZY)
    for name in type_names:
        _register(_STORE, name)
    return _STORE


def _register(store: Typestore, type_name: str) -> None:
    if type_name in store.fielddefs:
        return
    store.register(get_types_from_msg(definition(type_name), type_name))
    for field_type in fields(type_name).values():
        for package, name in _NESTED.findall(field_type):
            _register(store, f"{package}/msg/{name}")


def _qos_time(nanoseconds: int) -> QosTime:
    sec, nsec = divmod(int(nanoseconds), 1_000_000_000)
    return QosTime(sec, nsec)


def bag_qos(profile: QoSProfile) -> Qos:
    """An endpoint's QoS as a bag's metadata stores it (``offered_qos_profiles``)."""
    return Qos(
        history=QosHistory(int(profile.history)),
        depth=profile.depth,
        reliability=QosReliability(int(profile.reliability)),
        durability=QosDurability(int(profile.durability)),
        deadline=_qos_time(profile.deadline.nanoseconds),
        lifespan=_qos_time(profile.lifespan.nanoseconds),
        liveliness=QosLiveliness(int(profile.liveliness)),
        liveliness_lease_duration=_qos_time(profile.liveliness_lease_duration.nanoseconds),
        avoid_ros_namespace_conventions=profile.avoid_ros_namespace_conventions,
    )


def playback_qos(offered: Sequence[Qos], depth: int = 10) -> QoSProfile:
    """The QoS a player offers, adapted to the recorded publishers' as upstream's
    player does: reliable and transient-local only if every one of them was (so a
    late subscriber of a latched topic still gets it); reliable, volatile if none
    was recorded."""
    qos = QoSProfile(depth=depth)
    if any(q.reliability == QosReliability.BEST_EFFORT for q in offered):
        qos.reliability = ReliabilityPolicy.BEST_EFFORT
    if offered and all(q.durability == QosDurability.TRANSIENT_LOCAL for q in offered):
        qos.durability = DurabilityPolicy.TRANSIENT_LOCAL
    return qos


# -- writing -----------------------------------------------------------------------
class BagWriter:
    """A new rosbag2 folder at ``path`` (which must not exist), ``storage`` ``mcap`` or
    ``sqlite3``; ``close()`` (or leaving ``with``) writes ``metadata.yaml``."""

    def __init__(self, path: str | Path, storage: str = DEFAULT_STORAGE) -> None:
        if storage not in STORAGES:
            raise BagError(f"unknown storage '{storage}': choose one of {', '.join(STORAGES)}")
        self.path = Path(path)
        if self.path.exists():
            raise BagError(f"Output folder '{self.path}' already exists.")
        self._writer = Writer(
            self.path, version=Writer.VERSION_LATEST, storage_plugin=STORAGES[storage]
        )
        self._writer.open()
        self._connections: dict[str, Connection] = {}
        self.counts: dict[str, int] = {}

    def add_topic(
        self,
        topic: str,
        type_name: str,
        qos: Sequence[QoSProfile] = (),
        type_hash: str | None = None,
    ) -> None:
        """Declare ``topic`` of ``type_name`` (e.g. ``std_msgs/msg/String``), with the
        QoS its publishers offer and its type hash (``RIHS01_...``) as the graph reports
        it (default: computed from the definition)."""
        store = typestore([type_name])
        msgdef, _ = store.generate_msgdef(type_name, ros_version=2)
        self._connections[topic] = self._writer.add_connection(
            topic,
            type_name,
            msgdef=msgdef,
            rihs01=type_hash or store.hash_rihs01(type_name),
            serialization_format="cdr",
            offered_qos_profiles=[bag_qos(q) for q in qos],
        )
        self.counts[topic] = 0

    def write(self, topic: str, message: Any, stamp_ns: int) -> None:
        """Store ``message`` (a message object, or its CDR bytes) at ``stamp_ns``."""
        data = message if isinstance(message, bytes) else serialize_message(message)
        self._writer.write(self._connections[topic], stamp_ns, data)
        self.counts[topic] += 1

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())

    def close(self) -> None:
        self._writer.close()

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class Recorder:
    """Records topics of the live graph into a new bag (``ros2 bag record``).

    ``topics``: the names to record, or None for every visible topic (``-a``). A topic
    is subscribed once a publisher of it is on the graph (its type and QoS come from
    there); call :meth:`discover` again to pick up topics that appear later (the CLI
    does, every 100 ms, like upstream's topic polling). Each message is stored as the
    CDR bytes that arrived, stamped with ``node``'s clock at reception (simulated time
    on a node with ``use_sim_time``). ``on_subscribed(topic)`` is told of each new topic;
    a topic whose type is not installed here is left out, and ``on_unknown_type(text)``
    told once per type, in upstream's words.
    """

    def __init__(
        self,
        node: Node,
        path: str | Path,
        topics: Sequence[str] | None = None,
        storage: str = DEFAULT_STORAGE,
        on_subscribed: Callable[[str], None] | None = None,
        on_unknown_type: Callable[[str], None] | None = None,
    ) -> None:
        self.node = node
        self.wanted = None if topics is None else {graph.absolute_name(t) for t in topics}
        self.bag = BagWriter(path, storage)
        self.on_subscribed = on_subscribed
        self.on_unknown_type = on_unknown_type
        self._subscriptions: dict[str, Subscription] = {}
        self._unknown: dict[str, str] = {}  # topic: its type, left out

    @property
    def topics(self) -> list[str]:
        """The topics subscribed so far."""
        return sorted(self._subscriptions)

    def discover(self) -> list[str]:
        """Subscribe to the wanted topics that now have a publisher; the new ones."""
        new = []
        for name, types in self.node.get_topic_names_and_types():
            if name in self._subscriptions or name in self._unknown or not types:
                continue
            if self.wanted is None and graph.is_hidden(name):
                continue
            if self.wanted is not None and name not in self.wanted:
                continue
            publishers = self.node.get_publishers_info_by_topic(name)
            if not publishers:
                continue
            try:
                self._subscribe(name, types[0], publishers)
            except InterfaceError as error:
                self._left_out(name, types[0], error)
                continue
            new.append(name)
        return new

    def _left_out(self, topic: str, type_name: str, error: InterfaceError) -> None:
        if type_name not in self._unknown.values() and self.on_unknown_type is not None:
            self.on_unknown_type(
                f"Topic '{topic}' has unknown type '{type_name}' . Only topics with known "
                f"type are supported. Reason: '{error}"
            )
        self._unknown[topic] = type_name

    def _subscribe(self, topic: str, type_name: str, publishers: list[TopicEndpointInfo]) -> None:
        msg_type = message_class(type_name)
        type_hash = str(publishers[0].topic_type_hash)
        self.bag.add_topic(
            topic,
            type_name,
            [p.qos_profile for p in publishers],
            type_hash if type_hash.startswith("RIHS01_") else None,
        )
        qos = graph.qos_for_publishers(publishers, depth=RECORD_DEPTH)

        def store(data: bytes) -> None:
            self.bag.write(topic, data, self.node.get_clock().now().nanoseconds)

        self._subscriptions[topic] = self.node.create_subscription(
            msg_type, topic, store, qos, raw=True
        )
        if self.on_subscribed is not None:
            self.on_subscribed(topic)

    def close(self) -> None:
        """Stop recording and write the bag's metadata."""
        for subscription in self._subscriptions.values():
            self.node.destroy_subscription(subscription)
        self._subscriptions.clear()
        self.bag.close()


# -- reading -----------------------------------------------------------------------
def _reader(path: str | Path) -> Reader:
    path = Path(path)
    if not (path / "metadata.yaml").is_file():
        raise BagError(f"'{path}' is not a bag: no metadata.yaml in it")
    reader = Reader(path)
    try:
        reader.open()
    except ReaderError as error:
        raise BagError(f"'{path}' cannot be read as a bag: {error}") from None
    return reader


@dataclass(frozen=True)
class TopicCount:
    name: str
    type: str
    count: int
    serialization_format: str = "cdr"


@dataclass(frozen=True)
class BagInfo:
    """What ``ros2 bag info`` shows of a bag."""

    files: list[str]
    size: int
    storage: str
    ros_distro: str
    start_ns: int
    duration_ns: int
    message_count: int
    topics: list[TopicCount] = field(default_factory=list)

    def format(self) -> str:
        """The layout of upstream's ``ros2 bag info`` (rosbag2_py's format_bag_metadata)."""
        pad = " " * 19
        lines = [
            "",
            "Files:             " + f"\n{pad}".join(self.files),
            f"Bag size:          {format_size(self.size)}",
            f"Storage id:        {self.storage}",
            f"ROS Distro:        {self.ros_distro}",
            f"Duration:          {_seconds(self.duration_ns)}s",
            f"Start:             {_time_point(self.start_ns)}",
            f"End:               {_time_point(self.start_ns + self.duration_ns)}",
            f"Messages:          {self.message_count}",
            "Topic information: "
            + f"\n{pad}".join(
                f"Topic: {t.name} | Type: {t.type} | Count: {t.count} | "
                f"Serialization Format: {t.serialization_format}"
                for t in self.topics
            ),
            "Service:           0",
            "Service information: ",
        ]
        return "\n".join(lines)


def format_size(size: int) -> str:
    """``12.3 KiB``: bytes in binary units, one decimal past bytes (as upstream)."""
    value, units = float(size), ["B", "KiB", "MiB", "GiB", "TiB"]
    index = 0
    while value >= 1024 and index < len(units) - 1:
        value /= 1024
        index += 1
    return f"{value:.{0 if index == 0 else 1}f} {units[index]}"


def _seconds(ns: int) -> str:
    sec, nsec = divmod(ns, 1_000_000_000)
    return f"{sec}.{nsec:09d}"


def _time_point(ns: int) -> str:
    sec, nsec = divmod(ns, 1_000_000_000)
    local = datetime.fromtimestamp(sec)
    day = f"{local.day:>2}"
    return f"{local:%b} {day} {local:%Y %H:%M:%S}.{nsec:09d} ({_seconds(ns)})"


def info(path: str | Path) -> BagInfo:
    """The metadata of the bag at ``path`` (``ros2 bag info PATH``), as its
    ``metadata.yaml`` states it."""
    folder = Path(path)
    _reader(folder).close()  # a bag rosbags can open, or a BagError
    meta = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    files = [str(f) for f in meta["relative_file_paths"]]
    return BagInfo(
        files=files,
        size=sum((folder / f).stat().st_size for f in files),
        storage=meta["storage_identifier"],
        ros_distro=meta.get("ros_distro") or "unknown",
        start_ns=meta["starting_time"]["nanoseconds_since_epoch"] if meta["message_count"] else 0,
        duration_ns=meta["duration"]["nanoseconds"],
        message_count=meta["message_count"],
        topics=[
            TopicCount(
                t["topic_metadata"]["name"],
                t["topic_metadata"]["type"],
                t["message_count"],
                t["topic_metadata"]["serialization_format"],
            )
            for t in meta["topics_with_message_count"]
        ],
    )


@dataclass(frozen=True)
class BagMessage:
    topic: str
    type: str
    stamp_ns: int
    data: bytes

    def message(self) -> Any:
        """The message, deserialized into its live class."""
        return deserialize_message(self.data, message_class(self.type))


def read_messages(path: str | Path, topics: Sequence[str] | None = None) -> Iterator[BagMessage]:
    """The bag's messages in time order (``topics``: only those), CDR bytes and all."""
    reader = _reader(path)
    try:
        wanted = None if topics is None else {graph.absolute_name(t) for t in topics}
        connections = [c for c in reader.connections if wanted is None or c.topic in wanted]
        if not connections:
            return
        for connection, stamp, data in reader.messages(connections=connections):
            yield BagMessage(connection.topic, connection.msgtype, stamp, bytes(data))
    finally:
        reader.close()


# -- playing -----------------------------------------------------------------------
class Player:
    """Plays a bag's messages on its topics (``ros2 bag play``), from ``node``.

    Each message is published ``(stamp - first stamp) / rate`` seconds of wall time
    after the first one was, with the QoS its publishers offered (see :func:`playback_qos`);
    ``loop`` starts over at the end. ``spin(timeout)`` runs while waiting for the next
    message's time (default: ``node``'s callbacks).
    """

    def __init__(
        self,
        node: Node,
        path: str | Path,
        rate: float = 1.0,
        loop: bool = False,
        topics: Sequence[str] | None = None,
    ) -> None:
        if not rate > 0:
            raise BagError(f"rate must be > 0, not {rate}")
        self.node, self.path, self.rate, self.loop = node, Path(path), rate, loop
        reader = _reader(path)
        try:
            wanted = None if topics is None else {graph.absolute_name(t) for t in topics}
            self.publishers: dict[str, Publisher] = {}
            for c in reader.connections:
                if c.topic in self.publishers or (wanted is not None and c.topic not in wanted):
                    continue
                qos = playback_qos(getattr(c.ext, "offered_qos_profiles", []) or [])
                self.publishers[c.topic] = node.create_publisher(
                    message_class(c.msgtype), c.topic, qos
                )
        finally:
            reader.close()
        self.published = 0

    def wait_for_subscribers(
        self, timeout: float = graph.SETTLE_TIMEOUT_S, *, settle: bool = True
    ) -> bool:
        """Spin until each topic's publisher matched every subscription the graph shows
        for it, so none misses the first messages; whether they did within ``timeout``.
        With ``settle`` (subscribers in other processes) discovery settles first;
        without, only the subscriptions already known count (this process's own)."""

        def matched() -> bool:
            return all(
                pub.get_subscription_count() >= self.node.count_subscribers(topic)
                for topic, pub in self.publishers.items()
            )

        if settle:
            graph.settle(self.node, timeout=timeout)
        return graph.wait_for(lambda _: matched(), self.node, timeout=timeout)

    def play(self, spin: Callable[[float], None] | None = None) -> int:
        """Publish the bag once (or forever with ``loop``); the messages published."""
        executor = None
        if spin is None:
            executor = SingleThreadedExecutor(context=self.node.context)
            executor.add_node(self.node)
        wait = spin or (lambda timeout: executor.spin_once(timeout_sec=timeout))  # type: ignore[union-attr]
        try:
            while self._play_once(wait) and self.loop:
                pass
        finally:
            if executor is not None:
                executor.remove_node(self.node)
                executor.shutdown(timeout_sec=0)
        return self.published

    def _play_once(self, wait: Callable[[float], None]) -> bool:
        """Publish every message once at its time; whether there was any."""
        start: float | None = None
        first = 0
        for item in read_messages(self.path, list(self.publishers)):
            if start is not None:
                due = start + (item.stamp_ns - first) / 1e9 / self.rate
                while (left := due - time.monotonic()) > 0:
                    wait(min(left, 0.1))
            self.publishers[item.topic].publish(item.data)
            self.published += 1
            if start is None:
                # the schedule starts once the first message is out: a first publish
                # held up (a busy machine) does not shorten the recorded gaps after it
                start, first = time.monotonic(), item.stamp_ns
        return start is not None

    def close(self) -> None:
        for publisher in self.publishers.values():
            self.node.destroy_publisher(publisher)
        self.publishers.clear()
