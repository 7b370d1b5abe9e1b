"""``ros2 bag record / info / play``: real rosbag2 folders that other tools open.

The recorder and the player run as processes of their own (``python -m rosbook.cli``);
the publishing and subscribing nodes live in this process, in a context of their own.
Bags are read back with readers that share no code with the writer: the ``mcap``
library (Foxglove's) and sqlite3 itself; a bag written by ``rosbags`` directly (not
through this project) is played into a live subscriber.
"""

from __future__ import annotations

import re
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from geometry_msgs.msg import Twist
from mcap.reader import make_reader
from nav_msgs.msg import Odometry
from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from std_msgs.msg import String
from test_msgs.msg import Arrays, BasicTypes

from rosbook.runtime import bags, graph
from rosbook.viz import twin

#: Guards against a hang only (a subprocess CLI on a loaded machine starts slowly).
TIMEOUT_S = 60.0
WORDS = [f"hello {k}" for k in range(5)]
TWISTS = [(0.1 * k, -0.5 * k) for k in range(1, 4)]


def ros2(*argv: str, **kwargs: Any) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "rosbook.cli", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kwargs,
    )


def finish(process: subprocess.Popen[str]) -> tuple[str, str]:
    try:
        out, err = process.communicate(timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        process.kill()
        out, err = process.communicate()
        pytest.fail(f"timeout: {process.args} did not end in {TIMEOUT_S} s:\n{err}")
    assert process.returncode == 0 and "Traceback" not in err, err
    return out, err


@pytest.fixture
def node() -> Iterator[Node]:
    context = Context()
    context.init()
    node = Node("bag_test", context=context, start_parameter_services=False)
    yield node
    node.destroy_node()
    context.try_shutdown()


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """One live run recorded at once into an MCAP bag and a sqlite3 bag by ``ros2 bag
    record``: five Strings on /chatter, three Twists on /cmd_vel and one
    test_msgs/Arrays on /arrays, then Ctrl-C (SIGTERM for the sqlite3 one)."""
    tmp = tmp_path_factory.mktemp("bags")
    context = Context()
    context.init()
    node = Node("bag_talker", context=context, start_parameter_services=False)
    chatter = node.create_publisher(String, "chatter", 10)
    cmd_vel = node.create_publisher(Twist, "cmd_vel", 10)
    arrays = node.create_publisher(Arrays, "arrays", 10)  # a type outside rosbags' store
    paths = {storage: tmp / storage for storage in ("mcap", "sqlite3")}
    topics = ["/chatter", "cmd_vel", "/arrays"]
    recorders = {
        storage: ros2("bag", "record", "-o", str(path), "-s", storage, *topics)
        for storage, path in paths.items()
    }
    try:
        # both recorders' subscriptions matched both publishers: then nothing is missed
        both = len(recorders)
        assert graph.wait_for(
            lambda _: min(p.get_subscription_count() for p in (chatter, cmd_vel, arrays)) >= both,
            node,
            timeout=TIMEOUT_S,
        ), "timeout: the recorders' subscriptions never matched the publishers"
        for word in WORDS:
            chatter.publish(String(data=word))
        for v, w in TWISTS:
            msg = Twist()
            msg.linear.x, msg.angular.z = v, w
            cmd_vel.publish(msg)
        arrays.publish(Arrays(string_values=["a", "b", "c"]))
        # reliable: every message reached both recorders (their queues hold 100)
        for publisher in (chatter, cmd_vel, arrays):
            assert publisher.wait_for_all_acked(Duration(seconds=TIMEOUT_S)), "timeout: acks"
        [endpoint] = node.get_publishers_info_by_topic("/arrays")
        recorders["mcap"].send_signal(signal.SIGINT)  # Ctrl-C
        recorders["sqlite3"].send_signal(signal.SIGTERM)  # a launcher's or a shell's kill
        logs = {storage: "".join(finish(process)) for storage, process in recorders.items()}
    finally:
        for process in recorders.values():
            if process.poll() is None:
                process.kill()
                process.wait()
        node.destroy_node()
        context.try_shutdown()
    for log in logs.values():  # ROS logs go to stdout in isolated runs, else to stderr
        assert "[rosbag2_recorder]: Recording..." in log, log
        assert "Subscribed to topic '/chatter'" in log and "Subscribed to topic '/cmd_vel'" in log
        assert "Recording stopped" in log, log
    return {**paths, "arrays_hash": str(endpoint.topic_type_hash)}


def check_contents(rows: list[tuple[str, str, bytes]]) -> None:
    """(topic, type, CDR bytes) in time order: what the talker published, in order."""
    types = {"/chatter": String, "/cmd_vel": Twist}
    got: dict[str, list[Any]] = {"/chatter": [], "/cmd_vel": []}
    arrays = [deserialize_message(data, Arrays) for topic, _, data in rows if topic == "/arrays"]
    assert [list(m.string_values) for m in arrays] == [["a", "b", "c"]]
    for topic, type_name, data in rows:
        if topic == "/arrays":
            continue
        assert type_name == f"{types[topic].__module__.split('.')[0]}/msg/{types[topic].__name__}"
        got[topic].append(deserialize_message(data, types[topic]))
    assert [m.data for m in got["/chatter"]] == WORDS
    assert [(m.linear.x, m.angular.z) for m in got["/cmd_vel"]] == TWISTS


def test_record_writes_an_mcap_bag_that_the_mcap_library_reads(recorded) -> None:
    bag = recorded["mcap"]
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["storage_identifier"] == "mcap" and meta["message_count"] == 9
    # the type hash the graph reported, not one computed by rosbags
    hashes = {
        t["topic_metadata"]["name"]: t["topic_metadata"]["type_description_hash"]
        for t in meta["topics_with_message_count"]
    }
    # each topic's publishers' QoS, as the graph reported them
    [offered] = meta["topics_with_message_count"][0]["topic_metadata"]["offered_qos_profiles"]
    assert (offered["reliability"], offered["durability"]) == ("reliable", "volatile")
    assert hashes["/arrays"] == recorded["arrays_hash"] and hashes["/arrays"].startswith("RIHS01_")
    [file] = meta["relative_file_paths"]
    assert file.endswith(".mcap")
    rows = []
    with open(bag / file, "rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=True):
            assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            rows.append((channel.topic, schema.name, message.data))
            if channel.topic == "/cmd_vel":  # the definition names the nested type
                assert "geometry_msgs/Vector3" in schema.data.decode(), schema.data
    check_contents(rows)


def test_record_writes_a_sqlite3_bag_that_sqlite_reads(recorded) -> None:
    bag = recorded["sqlite3"]
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["storage_identifier"] == "sqlite3"
    [file] = meta["relative_file_paths"]
    with sqlite3.connect(bag / file) as db:
        rows = db.execute(
            "SELECT topics.name, topics.type, messages.data FROM messages "
            "JOIN topics ON messages.topic_id = topics.id ORDER BY messages.timestamp"
        ).fetchall()
        formats = {f for (f,) in db.execute("SELECT serialization_format FROM topics")}
    assert formats == {"cdr"}
    check_contents(rows)


def test_bag_info_prints_upstreams_layout(recorded) -> None:
    out, _ = finish(ros2("bag", "info", str(recorded["mcap"])))
    lines = out.splitlines()
    assert lines[0] == "" and lines[1].startswith("Files:             ")
    assert lines[1].endswith(".mcap")
    assert "Storage id:        mcap" in lines
    assert "Messages:          9" in lines
    for prefix in ("Bag size:          ", "Duration:          ", "Start:             "):
        assert any(line.startswith(prefix) for line in lines), (prefix, out)
    first = lines.index(next(line for line in lines if line.startswith("Topic information: ")))
    topics = [lines[first].removeprefix("Topic information: ")]
    topics += [line.removeprefix(" " * 19) for line in lines[first + 1 : first + 3]]
    assert sorted(topics) == [
        "Topic: /arrays | Type: test_msgs/msg/Arrays | Count: 1 | Serialization Format: cdr",
        "Topic: /chatter | Type: std_msgs/msg/String | Count: 5 | Serialization Format: cdr",
        "Topic: /cmd_vel | Type: geometry_msgs/msg/Twist | Count: 3 | Serialization Format: cdr",
    ], out
    assert lines[first + 3 :] == ["Service:           0", "Service information: "], out


def test_bag_info_of_a_folder_without_a_bag_is_one_line_and_exit_1(tmp_path) -> None:
    process = ros2("bag", "info", str(tmp_path))
    out, err = process.communicate(timeout=TIMEOUT_S)
    assert process.returncode == 1 and "Traceback" not in err
    assert "no metadata.yaml" in err and len(err.strip().splitlines()) == 1


# record is checked in the fast tier by the ``recorded`` tests
@pytest.mark.slow
def test_record_refuses_an_existing_output_folder_and_no_topics(tmp_path) -> None:
    process = ros2("bag", "record", "-o", str(tmp_path), "/chatter")
    _, err = process.communicate(timeout=TIMEOUT_S)
    assert process.returncode == 1 and f"Output folder '{tmp_path}' already exists." in err
    process = ros2("bag", "record", "-o", str(tmp_path / "new"))
    _, err = process.communicate(timeout=TIMEOUT_S)
    assert process.returncode == 1 and "Need to specify at least one option out of --all" in err
    assert not (tmp_path / "new").exists()


#: A subscription of a played topic that gets what the player sent before this process
#: discovered it (a volatile one would not: on a busy machine that can be the first
#: messages, as the player starts once it sees the subscription).
LATE_JOINER = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)

#: A recorded publisher that keeps its last messages for late joiners, as a bag stores it.
LATCHED = bags.bag_qos(LATE_JOINER)


def write_foreign_bag(path: Path, stamps_s: list[float]) -> Path:
    """A bag written with rosbags' own writer and serializer: a String ``played K`` on
    /chatter at each of ``stamps_s``, from a transient-local publisher."""
    store = get_typestore(Stores.ROS2_JAZZY)
    message = store.types["std_msgs/msg/String"]
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection(
            "/chatter", "std_msgs/msg/String", typestore=store, offered_qos_profiles=[LATCHED]
        )
        for k, stamp in enumerate(stamps_s):
            data = store.serialize_cdr(message(data=f"played {k}"), "std_msgs/msg/String")
            writer.write(connection, 1_700_000_000_000_000_000 + round(stamp * 1e9), data)
    return path


#: The gap between the foreign bag's recorded messages, in seconds.
FOREIGN_GAP_S = 0.4


@pytest.fixture(scope="module")
def foreign_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Six Strings on /chatter, ``FOREIGN_GAP_S`` apart (``write_foreign_bag``)."""
    return write_foreign_bag(
        tmp_path_factory.mktemp("foreign") / "bag", [FOREIGN_GAP_S * k for k in range(6)]
    )


def assert_played_at_the_recorded_gaps(sent: list[int], rate: float) -> None:
    """Each of the foreign bag's messages (DDS source timestamps ``sent``) was published
    no earlier after the first than the recorded gaps divided by ``rate``."""
    for k in range(1, len(sent)):
        assert sent[k] - sent[0] >= k * FOREIGN_GAP_S * 1e9 / rate - 1e6, (k, sent)


def test_play_publishes_a_foreign_bag_in_order_at_its_timing(foreign_bag, node) -> None:
    received: list[tuple[str, int]] = []
    node.create_subscription(
        String,
        "chatter",
        lambda msg, info: received.append((msg.data, info["source_timestamp"])),
        LATE_JOINER,
    )
    rate = 4.0
    player = ros2("bag", "play", str(foreign_bag), "-r", str(rate))
    try:
        done = graph.wait_for(lambda _: len(received) >= 6, node, timeout=TIMEOUT_S)
    finally:
        finish(player)
    assert done, f"timeout: received {received}"
    assert [data for data, _ in received] == [f"played {k}" for k in range(6)]
    assert_played_at_the_recorded_gaps([stamp for _, stamp in received], rate)


def test_play_keeps_the_recorded_gaps_after_a_first_message_held_up(foreign_bag, node) -> None:
    """A busy machine can hold the player up between reading the first message and
    publishing it (a stress run saw 45 ms, and the next gap came out 52 ms instead of
    100). The gaps after the first message are still the recorded ones over the rate:
    here its publish is held up 0.3 s, three gaps' worth at rate 4."""
    received: list[int] = []
    node.create_subscription(
        String,
        "chatter",
        lambda msg, info: received.append(info["source_timestamp"]),
        LATE_JOINER,
    )
    rate = 4.0
    player = bags.Player(node, foreign_bag, rate=rate)
    publisher = player.publishers["/chatter"]
    publish = publisher.publish

    def held_up_once(data: bytes) -> None:
        publisher.publish = publish  # type: ignore[method-assign]
        time.sleep(0.3)
        publish(data)

    publisher.publish = held_up_once  # type: ignore[method-assign]
    try:
        assert player.wait_for_subscribers(settle=False), "timeout: no match with the subscription"
        assert player.play() == 6
        done = graph.wait_for(lambda _: len(received) >= 6, node, timeout=TIMEOUT_S)
    finally:
        player.close()
    assert done, f"timeout: received {len(received)} of 6"
    assert_played_at_the_recorded_gaps(received, rate)


# play is checked in the fast tier by test_play_publishes_a_foreign_bag_in_order_at_its_timing
@pytest.mark.slow
def test_a_late_joiner_of_a_latched_topic_gets_what_the_player_sent_before_it(
    tmp_path, node
) -> None:
    """The player offers the recorded publisher's transient-local QoS, so a subscription
    that asks for it gets the messages sent before it was there (the book's playback
    relies on this). The bag's last message is 10 minutes after the others: the player is
    still running when the late subscription joins, and is stopped then."""
    bag = write_foreign_bag(tmp_path / "bag", [0.1 * k for k in range(6)] + [600.0])
    early: list[str] = []
    node.create_subscription(String, "chatter", lambda msg: early.append(msg.data), LATE_JOINER)
    player = ros2("bag", "play", str(bag))
    late: list[str] = []
    try:
        assert graph.wait_for(lambda _: len(early) >= 6, node, timeout=TIMEOUT_S), (
            f"timeout: the first subscription got {early}"
        )
        node.create_subscription(String, "chatter", lambda msg: late.append(msg.data), LATE_JOINER)
        done = graph.wait_for(lambda _: len(late) >= 6, node, timeout=TIMEOUT_S)
    finally:
        player.send_signal(signal.SIGINT)
        finish(player)
    assert done, f"timeout: the late subscription got {late}"
    assert late == [f"played {k}" for k in range(6)]


# play is checked in the fast tier by test_play_publishes_a_foreign_bag_in_order_at_its_timing
@pytest.mark.slow
def test_play_loop_starts_over_until_ctrl_c(foreign_bag, node) -> None:
    received: list[str] = []
    node.create_subscription(String, "chatter", lambda msg: received.append(msg.data), LATE_JOINER)
    player = ros2("bag", "play", str(foreign_bag), "-r", "20", "--loop")
    try:
        done = graph.wait_for(lambda _: len(received) >= 8, node, timeout=TIMEOUT_S)
    finally:
        player.send_signal(signal.SIGINT)
        finish(player)
    assert done, f"timeout: received {received}"
    once = [f"played {k}" for k in range(6)]
    assert received[:8] == once + once[:2]


def test_python_api_writes_messages_and_the_twin_replays_their_odometry(tmp_path) -> None:
    """``BagWriter`` takes message objects (serialized by rclpy), ``read_messages``
    gives them back in time order, and ``twin.odometry_frames`` turns a bag's odom into
    twin frames that end at its last pose (base_link's, as the message gives it)."""
    path = tmp_path / "drive"
    with bags.BagWriter(path, "sqlite3") as bag:
        bag.add_topic("/odom", "nav_msgs/msg/Odometry")
        for k in range(51):  # 1 s at 50 Hz, driving straight along x at 0.2 m/s
            msg = Odometry()
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(k * 20_000_000, 10**9)
            msg.pose.pose.position.x = 0.2 * k * 0.02
            msg.pose.pose.orientation.w = 1.0
            msg.twist.twist.linear.x = 0.2
            bag.write("/odom", msg, 5_000_000_000 - k)  # stored out of order on purpose
    assert bags.info(path).topics == [bags.TopicCount("/odom", "nav_msgs/msg/Odometry", 51)]
    messages = [m.message() for m in bags.read_messages(path)]
    assert [m.pose.pose.position.x for m in messages][:2] == [0.2 * 50 * 0.02, 0.2 * 49 * 0.02]
    frames = twin.odometry_frames(reversed(messages), fps=10)
    assert [round(f.t, 6) for f in frames] == [k / 10 for k in range(11)]
    assert frames[-1].x == pytest.approx(0.2) and frames[-1].yaw == 0.0
    # both wheels rolled 0.2 m: 0.2 / r = 5 rad
    assert frames[-1].left_wheel == pytest.approx(5.0) == frames[-1].right_wheel


def test_playback_offers_the_qos_every_recorded_publisher_offered() -> None:
    reliable = bags.bag_qos(QoSProfile(depth=10))
    latched = bags.bag_qos(QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    lossy = bags.bag_qos(QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT))
    assert latched.depth == 1 and lossy.reliability.name == "BEST_EFFORT"
    qos = bags.playback_qos([latched])
    assert (qos.reliability, qos.durability) == (
        ReliabilityPolicy.RELIABLE,
        DurabilityPolicy.TRANSIENT_LOCAL,
    )
    assert bags.playback_qos([latched, reliable]).durability == DurabilityPolicy.VOLATILE
    assert bags.playback_qos([reliable, lossy]).reliability == ReliabilityPolicy.BEST_EFFORT
    qos = bags.playback_qos([])
    assert (qos.reliability, qos.durability) == (
        ReliabilityPolicy.RELIABLE,
        DurabilityPolicy.VOLATILE,
    )


#: Bags written by the real rosbag2 (its own test data, see fixtures/rosbag2/README.md).
UPSTREAM_BAGS = Path(__file__).resolve().parent / "fixtures" / "rosbag2"


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_bag_info_of_upstreams_bag_prints_what_upstream_expects(storage: str) -> None:
    """Ported from rosbag2_tests' test_rosbag2_info_end_to_end.cpp (info_end_to_end_test)."""
    file = "cdr_test_0.mcap" if storage == "mcap" else "cdr_test_0.db3"
    out, _ = finish(ros2("bag", "info", "cdr_test", cwd=UPSTREAM_BAGS / storage))
    assert re.search(
        "\nFiles:             " + re.escape(file) + "\nBag size:          .*B"
        "\nStorage id:        " + storage + "\nROS Distro:        unknown"
        "\nDuration:          0.151137181s"
        "\nStart:             Apr  .+ 2020 .*:.*:36.763032325 \\(1586406456.763032325\\)"
        "\nEnd:               Apr  .+ 2020 .*:.*:36.914169506 \\(1586406456.914169506\\)"
        "\nMessages:          7"
        "\nTopic information: ",
        out,
    ), out
    assert (
        "Topic: /test_topic | Type: test_msgs/msg/BasicTypes | Count: 3 | "
        "Serialization Format: cdr\n"
    ) in out
    assert (
        "Topic: /array_topic | Type: test_msgs/msg/Arrays | Count: 4 | Serialization Format: cdr"
    ) in out


# play is checked in the fast tier by test_play_publishes_a_foreign_bag_in_order_at_its_timing
@pytest.mark.slow
def test_play_publishes_upstreams_bag_byte_for_byte(node) -> None:
    """Every message of rosbag2's own MCAP bag reaches a live subscriber, each topic's
    in the bag's order, as the same CDR bytes (read from the file by the mcap library)."""
    bag = UPSTREAM_BAGS / "mcap" / "cdr_test"
    with open(bag / "cdr_test_0.mcap", "rb") as stream:
        expected = [
            (channel.topic, message.data)
            for _, channel, message in make_reader(stream).iter_messages(log_time_order=True)
        ]
    received: list[tuple[str, bytes]] = []
    for topic, msg_type in (("/test_topic", BasicTypes), ("/array_topic", Arrays)):
        node.create_subscription(  # the bag's publishers were transient-local
            msg_type, topic, lambda data, t=topic: received.append((t, data)), LATE_JOINER, raw=True
        )
    player = ros2("bag", "play", str(bag))
    try:
        done = graph.wait_for(lambda _: len(received) >= 7, node, timeout=TIMEOUT_S)
    finally:
        finish(player)
    assert done, f"timeout: received {len(received)} of 7"
    assert len(expected) == 7 and len(received) == 7
    for topic in ("/test_topic", "/array_topic"):  # DDS orders messages within a topic
        assert [d for t, d in received if t == topic] == [d for t, d in expected if t == topic]


# record is checked in the fast tier by the ``recorded`` tests
@pytest.mark.slow
def test_record_leaves_out_a_topic_whose_type_is_not_installed(tmp_path, node) -> None:
    """As upstream: one warning, and the other topics are recorded. The recorder runs
    where test_msgs cannot be imported (a package this process has and it has not)."""
    chatter = node.create_publisher(String, "chatter", 10)
    node.create_publisher(Arrays, "arrays", 10)
    without_test_msgs = (
        "import sys; sys.modules['test_msgs'] = None; from rosbook.cli import main; "
        "sys.argv[0] = 'ros2'; sys.exit(main())"
    )
    recorder = subprocess.Popen(
        [sys.executable, "-c", without_test_msgs, "bag", "record", "-o", str(tmp_path / "b"),
         "/chatter", "/arrays"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )  # fmt: skip
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(recorder.stdout or []), daemon=True)
    reader.start()
    warning = "Topic '/arrays' has unknown type 'test_msgs/msg/Arrays' . Only topics with known"
    try:
        ready = graph.wait_for(
            lambda _: chatter.get_subscription_count() >= 1 and any(warning in x for x in lines),
            node,
            timeout=TIMEOUT_S,
        )
        chatter.publish(String(data="still recorded"))
        assert chatter.wait_for_all_acked(Duration(seconds=TIMEOUT_S)), "timeout: acks"
    finally:
        recorder.send_signal(signal.SIGINT)
        recorder.wait(timeout=TIMEOUT_S)
        reader.join(timeout=TIMEOUT_S)
    assert ready, f"timeout: {''.join(lines)}"
    assert recorder.returncode == 0, "".join(lines)
    assert sum(warning in x for x in lines) == 1, lines
    info = bags.info(tmp_path / "b")
    assert info.topics == [bags.TopicCount("/chatter", "std_msgs/msg/String", 1)]
