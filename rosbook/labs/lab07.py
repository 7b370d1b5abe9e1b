"""Lab 7's checks (frames and transforms): what the lab's test cells call as ``checks``.

Each check watches the student's node through real tf2 traffic: a subscription of its
own on ``/tf`` or ``/tf_static`` (to name a wrong frame or stamp) whose transforms fill
the judge's own tf2 ``Buffer`` (``rosbook.runtime.transforms``), which then answers the
lookups the student's transforms must satisfy. The stimuli (odometry, a tree of static
frames) are the judge's own publications. A node built in the student's kernel when graded
(``make_node``) is spun there meanwhile; the checks only wait for events.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.time import Time
from tf2_msgs.msg import TFMessage

from rosbook.labs.deferral import deferrable
from rosbook.labs.probes import *  # noqa: F403 (the shared probes, as checks.X)
from rosbook.labs.probes import (
    CheckFailed,
    Probe,
    Sender,
    TimedOut,
    node_publishes,
    node_subscribes,
)
from rosbook.labs.remote import EVENT_GUARD_S
from rosbook.runtime.session import ros
from rosbook.runtime.transforms import (
    TF_QOS,
    TF_STATIC_LISTENER_QOS,
    Buffer,
    BufferCore,
    StaticTransformBroadcaster,
    TransformException,
)

#: How far a translation (m) or a yaw (rad) may be from the expected one.
TOLERANCE = 1e-6

#: A planar pose: (x, y, yaw), metres and radians.
Pose2D = tuple[float, float, float]

#: A transform a check states: (parent frame, child frame, x, y, yaw).
Link = tuple[str, str, float, float, float]


def transform(
    parent: str, child: str, x: float, y: float, yaw: float, stamp: float = 0.0
) -> TransformStamped:
    """``child``'s frame in ``parent``'s: at (x, y, 0), turned by ``yaw`` about z."""
    out = TransformStamped()
    out.header.frame_id, out.child_frame_id = parent, child
    out.header.stamp = Time(nanoseconds=round(stamp * 1e9)).to_msg()
    out.transform.translation.x, out.transform.translation.y = float(x), float(y)
    out.transform.rotation.z, out.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return out


def planar(stamped: TransformStamped, what: str) -> Pose2D:
    """(x, y, yaw) of a transform that must lie in the plane (z = 0, turned about z only)."""
    t, r = stamped.transform.translation, stamped.transform.rotation
    if abs(t.z) > TOLERANCE or abs(r.x) > TOLERANCE or abs(r.y) > TOLERANCE:
        raise CheckFailed(
            f"{what}: translation z = {t.z:g}, rotation x, y = {r.x:g}, {r.y:g}; expected "
            "a pose in the plane (z = 0, turned about z only: x = y = 0 in the quaternion)"
        )
    return (t.x, t.y, 2 * math.atan2(r.z, r.w))


def _angle(a: float, b: float) -> float:
    """The difference of two angles, in (-pi, pi]."""
    return abs(math.remainder(a - b, math.tau))


def _shown(pose: Sequence[float]) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in pose) + ")"


def assert_pose(what: str, got: Sequence[float], expected: Sequence[float]) -> None:
    """``got`` (x, y, yaw) is ``expected`` within ``TOLERANCE`` (the yaw modulo a turn)."""
    if (
        abs(got[0] - expected[0]) > TOLERANCE
        or abs(got[1] - expected[1]) > TOLERANCE
        or _angle(got[2], expected[2]) > TOLERANCE
    ):
        raise CheckFailed(
            f"{what}: (x, y, yaw) = {_shown(got)}, expected {_shown(expected)} (metres, radians)"
        )


def _assert_frames(
    transforms: Sequence[TransformStamped], parent: str, child: str, topic: str
) -> TransformStamped:
    """The last of ``transforms`` whose child is ``child``; it must hang from ``parent``."""
    mine = [t for t in transforms if t.child_frame_id == child]
    if not mine:
        sent = sorted({f"{t.header.frame_id} -> {t.child_frame_id}" for t in transforms})
        raise CheckFailed(
            f"published no transform of frame '{child}' on {topic} (it sent {', '.join(sent)}); "
            f"expected '{parent}' -> '{child}': is child_frame_id set?"
        )
    last = mine[-1]
    if last.header.frame_id != parent:
        raise CheckFailed(
            f"published {child} in frame '{last.header.frame_id}', expected '{parent}' "
            "(the parent is header.frame_id)"
        )
    return last


def _look_up(buffer: BufferCore, parent: str, child: str, at: Time) -> TransformStamped:
    """``buffer``'s transform of ``child`` in ``parent``; a check failure if it has none."""
    try:
        return buffer.lookup_transform_core(parent, child, at)
    except TransformException as exc:
        raise CheckFailed(
            f"the judge's tf2 Buffer could not look up {child} in {parent}: {exc}"
        ) from None


def _heard(
    probe: Probe, count: int, wanted: Callable[[TransformStamped], bool], what: str
) -> list[TransformStamped]:
    """The transforms of the probe's messages after its first ``count``, once a ``wanted``
    one is among them or ``EVENT_GUARD_S`` has passed: then, if none came at all, a
    timeout (not wrong); else what came (the check names what is wrong in it)."""

    def transforms() -> list[TransformStamped]:
        return [t for msg in probe.received.messages[count:] for t in msg.transforms]

    ros.spin_until(lambda: any(wanted(t) for t in transforms()), timeout=EVENT_GUARD_S)
    if not transforms():
        raise TimedOut(f"nothing arrived on {probe.topic} within {EVENT_GUARD_S:.0f} s {what}")
    return transforms()


# -- task 1: a static transform --------------------------------------------------------


def assert_static_transform(
    node: Node, parent: str, child: str, x: float, y: float, yaw: float
) -> None:
    """``node`` sends ``parent`` -> ``child`` at (x, y, yaw) on /tf_static, as the judge's
    tf2 Buffer sees it at any time."""
    node_publishes(node, "/tf_static", TFMessage)
    probe = Probe("/tf_static", TFMessage, TF_STATIC_LISTENER_QOS)
    try:
        probe.wait_for_publisher()
        transforms = _heard(
            probe, 0, lambda t: t.child_frame_id == child, f"from node '{node.get_name()}'"
        )
        last = _assert_frames(transforms, parent, child, "/tf_static")
        buffer = BufferCore()
        buffer.set_transform_static(last, "judge")
        got = planar(_look_up(buffer, parent, child, Time()), f"{child} in {parent}")
        assert_pose(f"{child} in {parent} on /tf_static", got, (x, y, yaw))
    finally:
        probe.close()


# -- task 2: odometry as a dynamic transform -------------------------------------------


def odometry(frame: str, child: str, stamp: float, x: float, y: float, yaw: float) -> Odometry:
    """An Odometry message: ``child`` at (x, y, yaw) in ``frame`` at ``stamp`` (s)."""
    pose = transform(frame, child, x, y, yaw, stamp)
    msg = Odometry()
    msg.header, msg.child_frame_id = pose.header, child
    p = msg.pose.pose
    p.position.x, p.position.y = pose.transform.translation.x, pose.transform.translation.y
    p.orientation = pose.transform.rotation
    return msg


def assert_broadcasts_odometry(
    node: Node, poses: Sequence[tuple[str, str, float, float, float, float]]
) -> None:
    """For each (frame, child, stamp, x, y, yaw), an Odometry message on /odom makes
    ``node`` send ``frame`` -> ``child`` on /tf, stamped as the message, at its pose."""
    node_subscribes(node, "/odom", Odometry)
    node_publishes(node, "/tf", TFMessage)
    probe = Probe("/tf", TFMessage, TF_QOS)
    sender = Sender("/odom", Odometry)
    buffer = Buffer()
    try:
        probe.wait_for_publisher()
        sender.wait_for_subscriber()
        for frame, child, stamp, x, y, yaw in poses:
            count = len(probe.received.messages)
            sender.pub.publish(odometry(frame, child, stamp, x, y, yaw))
            nanoseconds = round(stamp * 1e9)

            def stamped(t: TransformStamped, ns: int = nanoseconds) -> bool:
                return Time.from_msg(t.header.stamp).nanoseconds == ns

            transforms = _heard(
                probe,
                count,
                lambda t, s=stamped, c=child: t.child_frame_id == c and s(t),
                f"after an Odometry message on /odom stamped {stamp:g} s",
            )
            # another node of the same class (still alive in the notebook) may answer too
            last = _assert_frames([t for t in transforms if stamped(t)] or transforms,
                                  frame, child, "/tf")  # fmt: skip
            sent = Time.from_msg(last.header.stamp)
            if sent.nanoseconds != nanoseconds:
                raise CheckFailed(
                    f"published {child} stamped {sent.nanoseconds / 1e9:.3f} s, expected the "
                    f"odometry's stamp {stamp:g} s (header.stamp of the /odom message)"
                )
            buffer.set_transform(last, "judge")
            got = planar(_look_up(buffer, frame, child, sent), f"{child} in {frame}")
            assert_pose(f"{child} in {frame} at {stamp:g} s", got, (x, y, yaw))
    finally:
        sender.close()
        probe.close()


# -- task 3: a lookup ------------------------------------------------------------------


def expected_pose(links: Sequence[Link], target: str, source: str) -> Pose2D:
    """Where ``source``'s origin is in ``target`` through the tree of ``links``, as the
    judge's own tf2 buffer composes it."""
    buffer = BufferCore()
    for link in links:
        buffer.set_transform_static(transform(*link), "judge")
    return planar(_look_up(buffer, target, source, Time()), f"{source} in {target}")


def assert_locates(node: Any, links: Sequence[Link], target: str, source: str) -> None:
    """With ``links`` on /tf_static (the judge's), ``node.where(target, source)`` comes
    to answer (x, y, yaw) of ``source`` in ``target`` (it answers None until it can)."""
    expected = expected_pose(links, target, source)
    sender = Node("frames_broadcaster")
    answer: list[Any] = [None]
    call = f"where({target!r}, {source!r})"

    def answered() -> bool:
        try:
            answer[0] = node.where(target, source)
        except CheckFailed:
            raise
        except Exception as exc:  # the student's method raised: said, with what it raised
            raise CheckFailed(
                f"{call} raised {type(exc).__name__}: {exc}; it must return None while "
                "the buffer cannot answer"
            ) from None
        return answer[0] is not None

    try:
        StaticTransformBroadcaster(sender).sendTransform([transform(*link) for link in links])
        if not ros.spin_until(answered, timeout=EVENT_GUARD_S):
            raise TimedOut(
                f"{call} still returned None {EVENT_GUARD_S:.0f} s after the frames were sent "
                "on /tf_static: does a TransformListener fill the node's Buffer?"
            )
    finally:
        ros.remove(sender)
    got = answer[0]
    if not (
        isinstance(got, (tuple, list))
        and len(got) == 3
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in got)
    ):
        raise CheckFailed(f"{call} returned {got!r}, expected a tuple (x, y, yaw) of numbers")
    assert_pose(f"{call} (where {source} is in {target})", [float(v) for v in got], expected)


deferrable(globals())
