"""tf2_ros's API (``rosbook.runtime.transforms``, imported as ``tf2_ros``) on a chain of frames.

What tf2 answers, and its error messages, are upstream's (ros2/geometry2 jazzy:
``tf2/src/buffer_core.cpp``, ``tf2/src/cache.cpp``, ``tf2_ros_py/tf2_ros``).
"""

from __future__ import annotations

import math
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import rclpy
from geometry_msgs.msg import TransformStamped
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.time import Time

from tf2_ros import (
    Buffer,
    ConnectivityException,
    ExtrapolationException,
    InvalidArgumentException,
    LookupException,
    TransformException,
    TransformListener,
)
from tf2_ros.buffer import Buffer as BufferFromModule

BROADCASTERS = Path(__file__).parent / "fixtures" / "tf" / "broadcasters.py"


def stamped(parent: str, child: str, seconds: float, x: float = 0.0, y: float = 0.0,
            yaw: float = 0.0) -> TransformStamped:  # fmt: skip
    t = TransformStamped()
    t.header.stamp = Time(nanoseconds=round(seconds * 1e9)).to_msg()
    t.header.frame_id, t.child_frame_id = parent, child
    t.transform.translation.x, t.transform.translation.y = x, y
    t.transform.rotation.z, t.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return t


def at(seconds: float) -> Time:
    return Time(nanoseconds=round(seconds * 1e9))


def xy_yaw(t: TransformStamped) -> tuple[float, float, float]:
    r = t.transform.rotation
    yaw = math.atan2(2 * (r.w * r.z + r.x * r.y), 1 - 2 * (r.y**2 + r.z**2))
    return (round(t.transform.translation.x, 9), round(t.transform.translation.y, 9),
            round(yaw, 9))  # fmt: skip


@pytest.fixture
def chain() -> Buffer:
    """world -> odom (static, x 1) -> base_link (x 0, 1, 2 at 1, 2, 3 s; yaw 0 to pi/2)
    -> laser (static, x 0.5); and a second tree, moon -> crater."""
    buffer = Buffer()
    buffer.set_transform_static(stamped("world", "odom", 0, x=1.0), "test")
    for s in (1, 2, 3):
        buffer.set_transform(stamped("odom", "base_link", s, x=s - 1.0, yaw=(s - 1) * math.pi / 4),
                             "test")  # fmt: skip
    buffer.set_transform_static(stamped("base_link", "laser", 0, x=0.5), "test")
    buffer.set_transform_static(stamped("moon", "crater", 0, y=2.0), "test")
    return buffer


def test_tf2_ros_modules_give_upstreams_names() -> None:
    from tf2_ros.static_transform_broadcaster import StaticTransformBroadcaster
    from tf2_ros.transform_broadcaster import TransformBroadcaster
    from tf2_ros.transform_listener import TransformListener as ListenerFromModule

    assert BufferFromModule is Buffer and ListenerFromModule is TransformListener
    assert StaticTransformBroadcaster.sendTransform and TransformBroadcaster.sendTransform
    for error in (LookupException, ConnectivityException, ExtrapolationException,
                  InvalidArgumentException):  # fmt: skip
        assert issubclass(error, TransformException)


def test_lookup_composes_the_chain_at_a_stamp(chain: Buffer) -> None:
    t = chain.lookup_transform("world", "laser", at(3))
    assert (t.header.frame_id, t.child_frame_id) == ("world", "laser")
    # base_link at x=1+2=3 facing +y: the laser, 0.5 m ahead of it, is at (3, 0.5)
    assert xy_yaw(t) == (3.0, 0.5, round(math.pi / 2, 9))


def test_lookup_the_other_way_is_the_inverse(chain: Buffer) -> None:
    t = chain.lookup_transform("laser", "world", at(3))
    # world's origin, seen from the laser at (3, 0.5) facing +y: 0.5 behind, 3 to its right
    assert xy_yaw(t) == (-0.5, 3.0, round(-math.pi / 2, 9))


def test_lookup_between_stamps_interpolates(chain: Buffer) -> None:
    t = chain.lookup_transform("odom", "base_link", at(1.5))
    assert xy_yaw(t) == (0.5, 0.0, round(math.pi / 8, 9))
    assert Time.from_msg(t.header.stamp).nanoseconds == at(1.5).nanoseconds


def test_time_zero_is_the_latest_common_time(chain: Buffer) -> None:
    t = chain.lookup_transform("world", "base_link", Time())
    assert Time.from_msg(t.header.stamp).nanoseconds == at(3).nanoseconds
    assert xy_yaw(t) == (3.0, 0.0, round(math.pi / 2, 9))
    # only static links: time 0 stays 0
    static = chain.lookup_transform("moon", "crater", Time())
    assert Time.from_msg(static.header.stamp).nanoseconds == 0


def test_time_travel_goes_through_the_fixed_frame(chain: Buffer) -> None:
    # where base_link was at 1 s (odom's origin, facing +x), seen from base_link at 3 s
    # (at odom x=2, facing +y): 2 m to its left, turned -90 degrees
    t = chain.lookup_transform_full("base_link", at(3), "base_link", at(1), "world")
    assert xy_yaw(t) == (0.0, 2.0, round(-math.pi / 2, 9))
    assert (t.header.frame_id, t.child_frame_id) == ("base_link", "base_link")
    assert Time.from_msg(t.header.stamp).nanoseconds == at(3).nanoseconds
    assert not chain.can_transform_full("base_link", at(3), "base_link", at(0.5), "world")
    with pytest.raises(LookupException, match="argument fixed_frame does not exist"):
        chain.lookup_transform_full("base_link", at(3), "base_link", at(1), "nowhere")


def test_a_static_transform_holds_at_every_time(chain: Buffer) -> None:
    for seconds in (0.0, 2.0, 1000.0):
        assert xy_yaw(chain.lookup_transform("world", "odom", at(seconds))) == (1.0, 0.0, 0.0)


def test_extrapolation_into_the_future_says_so_as_tf2_does(chain: Buffer) -> None:
    with pytest.raises(ExtrapolationException) as raised:
        chain.lookup_transform("world", "laser", at(3.5))
    assert str(raised.value) == (
        "Lookup would require extrapolation into the future.  Requested time 3.500000 but the "
        "latest data is at time 3.000000, when looking up transform from frame [laser] to "
        "frame [world]"
    )


def test_extrapolation_into_the_past_says_so_as_tf2_does(chain: Buffer) -> None:
    with pytest.raises(ExtrapolationException) as raised:
        chain.lookup_transform("laser", "world", at(0.25))
    assert str(raised.value) == (
        "Lookup would require extrapolation into the past.  Requested time 0.250000 but the "
        "earliest data is at time 1.000000, when looking up transform from frame [world] to "
        "frame [laser]"
    )


def test_one_stamp_only_answers_at_that_stamp() -> None:
    buffer = Buffer()
    buffer.set_transform(stamped("map", "odom", 5.0, x=1.0), "test")
    assert xy_yaw(buffer.lookup_transform("map", "odom", at(5.0)))[0] == 1.0
    with pytest.raises(ExtrapolationException, match=r"^Lookup would require extrapolation at "
                       r"time 6\.000000, but only time 5\.000000 is in the buffer, when looking "
                       r"up transform from frame \[odom\] to frame \[map\]$"):  # fmt: skip
        buffer.lookup_transform("map", "odom", at(6.0))


def test_unknown_frames_and_separate_trees_raise_tf2s_errors(chain: Buffer) -> None:
    with pytest.raises(LookupException) as unknown:
        chain.lookup_transform("nowhere", "laser", Time())
    assert str(unknown.value) == (
        '"nowhere" passed to lookupTransform argument target_frame does not exist. '
    )
    with pytest.raises(ConnectivityException) as apart:
        chain.lookup_transform("world", "crater", Time())
    assert str(apart.value) == (
        "Could not find a connection between 'world' and 'crater' because they are not part of "
        "the same tree.Tf has two or more unconnected trees."
    )
    with pytest.raises(InvalidArgumentException, match="cannot start with a '/'"):
        chain.lookup_transform("/world", "laser", Time())


def test_can_transform_answers_without_raising(chain: Buffer) -> None:
    assert chain.can_transform("world", "laser", at(2))
    assert not chain.can_transform("world", "laser", at(4))
    assert chain.can_transform("world", "nowhere", Time(), return_debug_tuple=True) == (
        False,
        'Invalid frame ID "nowhere" passed to canTransform argument source_frame - frame does '
        "not exist",
    )


def test_the_cache_forgets_what_is_older_than_its_time() -> None:
    buffer = Buffer(cache_time=Duration(seconds=2))
    for s in range(10):
        buffer.set_transform(stamped("odom", "base_link", s, x=float(s)), "test")
    # kept: what is at most 2 s older than the newest stamp before the last insert (8 s)
    assert buffer.can_transform("odom", "base_link", at(6))
    with pytest.raises(ExtrapolationException, match="earliest data is at time 6.000000"):
        buffer.lookup_transform("odom", "base_link", at(5.5))
    assert not buffer.set_transform(stamped("odom", "base_link", 1, x=1.0), "test")


def test_bad_transforms_are_ignored_with_tf2s_words(chain: Buffer) -> None:
    bad = stamped("odom", "odom", 1.0)
    assert chain.set_transform(bad, "test") is False
    unnormalised = stamped("odom", "wheel", 1.0)
    unnormalised.transform.rotation.w = 2.0
    assert chain.set_transform(unnormalised, "test") is False
    assert not chain.can_transform("odom", "wheel", Time())


def test_timeout_returns_as_soon_as_the_transform_arrives() -> None:
    import threading

    buffer = Buffer()
    later = threading.Timer(0.2, buffer.set_transform, (stamped("map", "odom", 1.0), "test"))
    later.start()
    t = buffer.lookup_transform("map", "odom", at(1.0), timeout=Duration(seconds=60))
    assert t.child_frame_id == "odom"
    with pytest.raises(LookupException):  # nothing comes: the timeout ends the wait
        buffer.lookup_transform("map", "nowhere", Time(), timeout=Duration(seconds=0.1))


@pytest.fixture
def broadcaster() -> Iterator[subprocess.Popen[str]]:
    """The chain of broadcasters.py, in a process of its own (tf2_ros's API)."""
    process = subprocess.Popen([sys.executable, str(BROADCASTERS)], stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True)  # fmt: skip
    yield process
    process.terminate()
    out, _ = process.communicate(timeout=60)
    assert "Traceback" not in out, out


def test_a_listener_hears_tf_and_tf_static_from_another_process(broadcaster) -> None:
    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node("tf_listener_test", context=context)
    buffer = Buffer()
    listener = TransformListener(buffer, node, spin_thread=True)
    try:
        # waits for the event; 120 s only guards a hang
        t = buffer.lookup_transform("world", "base_link", at(2), timeout=Duration(seconds=120))
        assert xy_yaw(t) == (2.0, 0.0, round(math.pi / 4, 9))
        types = dict(node.get_topic_names_and_types())
        assert types["/tf"] == ["tf2_msgs/msg/TFMessage"]
        assert types["/tf_static"] == ["tf2_msgs/msg/TFMessage"]
        static_qos = node.get_publishers_info_by_topic("/tf_static")[0].qos_profile
        assert static_qos.durability.name == "TRANSIENT_LOCAL"
    finally:
        listener.unregister()
        node.destroy_node()
        rclpy.shutdown(context=context)


def test_a_late_listener_still_gets_the_static_transforms(broadcaster) -> None:
    context = rclpy.Context()
    rclpy.init(context=context)
    early = Node("tf_early", context=context)
    try:  # the broadcaster is up once its /tf reaches us; only then the late listener starts
        early_buffer = Buffer()
        early_listener = TransformListener(early_buffer, early, spin_thread=True)
        early_buffer.lookup_transform("odom", "base_link", at(1), timeout=Duration(seconds=120))
        early_listener.unregister()
        late = Node("tf_late", context=context)
        buffer = Buffer()
        listener = TransformListener(buffer, late, spin_thread=True)
        t = buffer.lookup_transform("world", "odom", Time(), timeout=Duration(seconds=120))
        assert xy_yaw(t) == (1.0, 0.0, 0.0)
        listener.unregister()
        late.destroy_node()
    finally:
        early.destroy_node()
        rclpy.shutdown(context=context)


def test_tf_message_has_the_type_hash_of_jazzys_tf2_msgs() -> None:
    # What a full install's tools check before they read /tf: the RIHS01 hash of the type,
    # here as rclpy announces ours, against rosbags' own store of Jazzy's message types.
    from rosbags.typesys import Stores, get_typestore
    from tf2_msgs.msg import TFMessage

    jazzy = get_typestore(Stores.ROS2_JAZZY).hash_rihs01("tf2_msgs/msg/TFMessage")
    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node("tf_hash", context=context)
    try:
        node.create_publisher(TFMessage, "/tf", 10)
        announced = node.get_publishers_info_by_topic("/tf")[0].topic_type_hash
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)
    assert str(announced) == jazzy


def test_a_static_broadcaster_sends_every_child_it_was_given_in_each_message() -> None:
    from tf2_ros import StaticTransformBroadcaster

    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node("tf_static_many", context=context)
    try:
        broadcaster = StaticTransformBroadcaster(node)
        broadcaster.sendTransform(stamped("base_link", "laser", 0, x=0.1))
        broadcaster.sendTransform([stamped("base_link", "camera", 0, x=0.2),
                                   stamped("base_link", "laser", 0, x=9.0)])  # fmt: skip
        # one latched message with both children; the first laser transform is kept
        sent = [(t.child_frame_id, t.transform.translation.x)
                for t in broadcaster.net_message.transforms]  # fmt: skip
        assert sent == [("laser", 0.1), ("camera", 0.2)]
        buffer = Buffer()
        listener = TransformListener(buffer, node, spin_thread=True)  # joins after both sends
        assert buffer.can_transform("laser", "camera", Time(), timeout=Duration(seconds=120))
        listener.unregister()
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)


def test_a_jump_back_in_time_clears_the_buffer() -> None:
    # simulated time restarting (a new simulation, a bag played again) empties it, as tf2_ros
    from rclpy.parameter import Parameter

    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node("tf_jump", context=context,
                parameter_overrides=[Parameter("use_sim_time", value=True)])  # fmt: skip
    try:
        clock = node.get_clock()
        clock.set_ros_time_override(Time(seconds=5, clock_type=clock.clock_type))
        buffer = Buffer(node=node)
        buffer.set_transform(stamped("odom", "base_link", 5.0), "test")
        clock.set_ros_time_override(Time(seconds=4.5, clock_type=clock.clock_type))
        assert buffer.can_transform("odom", "base_link", at(5.0))  # half a second back: kept
        clock.set_ros_time_override(Time(seconds=1, clock_type=clock.clock_type))
        assert not buffer.can_transform("odom", "base_link", at(5.0))
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)
