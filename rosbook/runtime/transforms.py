"""Frames and transforms over ``/tf`` and ``/tf_static``, with tf2_ros's names and behaviour.

No tf2 wheel exists, so this module stands in for ``tf2`` (the buffer core) and
``tf2_ros`` (``Buffer``, ``TransformListener``, ``TransformBroadcaster``,
``StaticTransformBroadcaster``); the package ``tf2_ros`` of this repository re-exports it
under upstream's module names, so the official tutorials' nodes run unchanged. What
travels is real: ``tf2_msgs/msg/TFMessage`` (the course's own build of upstream's
definition, the same name and fields: a full install's tools read it) on ``/tf``
(volatile) and ``/tf_static`` (transient local), with upstream's QoS.

The buffer keeps, for each child frame, its parent's transform over time (10 s by
default; a static transform holds at every time). A lookup walks both frames up to
their common ancestor and composes the transforms along the way, interpolating between
the two stamps around the requested time (linearly for the translation, spherically for
the rotation). It never extrapolates: a time after the newest or before the oldest
stamp of a link raises ``ExtrapolationException``; time 0 asks for the latest time every
link of the chain has. Errors carry upstream's messages (ros2/geometry2, jazzy:
``tf2/src/buffer_core.cpp``, ``tf2/src/cache.cpp``).
"""

from __future__ import annotations

import bisect
import math
import threading
import time as _time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import rclpy.logging
from geometry_msgs.msg import TransformStamped
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.clock import Clock, JumpThreshold
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile
from rclpy.time import Time

#: How long a buffer keeps transforms by default (tf2's BUFFER_CORE_DEFAULT_CACHE_TIME).
DEFAULT_CACHE_TIME = Duration(seconds=10)

#: A lookup's timeout that does not wait (tf2_ros's default, ``Duration()``).
NO_WAIT = Duration()

#: The longest chain of frames a lookup walks before it calls the tree a loop (tf2's).
MAX_GRAPH_DEPTH = 1000

#: How far from 1 a rotation's squared norm may be (tf2's QUATERNION_NORMALIZATION_TOLERANCE).
QUATERNION_TOLERANCE = 10e-3

_LOGGER = rclpy.logging.get_logger("tf2")

TF_QOS = QoSProfile(depth=100, durability=DurabilityPolicy.VOLATILE,
                    history=HistoryPolicy.KEEP_LAST)  # fmt: skip
TF_STATIC_LISTENER_QOS = QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                                    history=HistoryPolicy.KEEP_LAST)  # fmt: skip
TF_STATIC_BROADCASTER_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                                       history=HistoryPolicy.KEEP_LAST)  # fmt: skip


class TransformException(Exception):
    """Base of every tf2 error (``tf2.TransformException``)."""


class LookupException(TransformException):
    """A frame the buffer has never heard of."""


class ConnectivityException(TransformException):
    """Two frames that are not in the same tree."""


class ExtrapolationException(TransformException):
    """A time outside what the buffer holds for some link of the chain."""


class InvalidArgumentException(TransformException):
    """A frame id that cannot be one (empty, or starting with '/'), or a bad transform."""


class TimeoutException(TransformException):
    """A wait that ran out (``tf2.TimeoutException``)."""


# -- rigid transforms: (rotation quaternion x, y, z, w; translation x, y, z) ---------------

Quaternion = tuple[float, float, float, float]
Vector = tuple[float, float, float]


def _qmul(a: Quaternion, b: Quaternion) -> Quaternion:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def _rotate(q: Quaternion, v: Vector) -> Vector:
    x, y, z, _ = _qmul(_qmul(q, (v[0], v[1], v[2], 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


@dataclass(frozen=True)
class Rigid:
    """``p_parent = rotation * p_child + translation``."""

    rotation: Quaternion = (0.0, 0.0, 0.0, 1.0)
    translation: Vector = (0.0, 0.0, 0.0)

    def __mul__(self, other: Rigid) -> Rigid:
        moved = _rotate(self.rotation, other.translation)
        return Rigid(
            _qmul(self.rotation, other.rotation),
            (moved[0] + self.translation[0], moved[1] + self.translation[1],
             moved[2] + self.translation[2]),
        )  # fmt: skip

    def inverse(self) -> Rigid:
        conjugate = (-self.rotation[0], -self.rotation[1], -self.rotation[2], self.rotation[3])
        back = _rotate(conjugate, self.translation)
        return Rigid(conjugate, (-back[0], -back[1], -back[2]))


def _slerp(a: Quaternion, b: Quaternion, ratio: float) -> Quaternion:
    dot = sum(x * y for x, y in zip(a, b))
    if dot < 0.0:  # the shorter way round
        b, dot = (-b[0], -b[1], -b[2], -b[3]), -dot
    if dot > 0.9995:
        mixed = tuple(x + ratio * (y - x) for x, y in zip(a, b))
    else:
        theta = math.acos(dot)
        wa = math.sin((1.0 - ratio) * theta) / math.sin(theta)
        wb = math.sin(ratio * theta) / math.sin(theta)
        mixed = tuple(wa * x + wb * y for x, y in zip(a, b))
    norm = math.sqrt(sum(x * x for x in mixed))
    return (mixed[0] / norm, mixed[1] / norm, mixed[2] / norm, mixed[3] / norm)


def _interpolate(one: _Stored, two: _Stored, stamp: int) -> Rigid:
    if two.stamp == one.stamp:
        return two.rigid
    ratio = (stamp - one.stamp) / (two.stamp - one.stamp)
    t1, t2 = one.rigid.translation, two.rigid.translation
    return Rigid(
        _slerp(one.rigid.rotation, two.rigid.rotation, ratio),
        (t1[0] + ratio * (t2[0] - t1[0]), t1[1] + ratio * (t2[1] - t1[1]),
         t1[2] + ratio * (t2[2] - t1[2])),
    )  # fmt: skip


def _stamped(rigid: Rigid, target: str, source: str, stamp: object) -> TransformStamped:
    out = TransformStamped()
    out.header.frame_id, out.header.stamp, out.child_frame_id = target, stamp, source
    r, t = out.transform.rotation, out.transform.translation
    r.x, r.y, r.z, r.w = rigid.rotation
    t.x, t.y, t.z = rigid.translation
    return out


def _rigid(transform: TransformStamped) -> Rigid:
    r, t = transform.transform.rotation, transform.transform.translation
    return Rigid((r.x, r.y, r.z, r.w), (t.x, t.y, t.z))


def _seconds(stamp: int) -> str:
    """A time as tf2 prints it (``displayTimePoint``: seconds, six decimals)."""
    return f"{stamp / 1e9:.6f}"


# -- the buffer core: a time-ordered cache per child frame -------------------------------


@dataclass(frozen=True)
class _Stored:
    stamp: int  # nanoseconds
    parent: str
    rigid: Rigid


class _Missing(Exception):
    """No data for a link at a time: tf2's error code, and its message."""

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message


class _Link:
    """The transforms from one child frame to its parent(s), newest last."""

    def __init__(self, cache_ns: int, static: bool) -> None:
        self.cache_ns = cache_ns
        self.static = static
        self.stored: list[_Stored] = []

    def insert(self, item: _Stored) -> bool:
        if self.static:
            self.stored = [item]
            return True
        latest = self.stored[-1].stamp if self.stored else 0
        if self.stored:  # prune what fell out of the cache, and refuse what is older
            keep_from = bisect.bisect_left([s.stamp for s in self.stored], latest - self.cache_ns)
            del self.stored[:keep_from]
            if item.stamp < latest - self.cache_ns:
                return False
        if item not in self.stored:
            stamps = [s.stamp for s in self.stored]
            self.stored.insert(bisect.bisect_right(stamps, item.stamp), item)
        return True

    def latest(self) -> tuple[int, str]:
        """The newest stamp (0 for a static link) and its parent."""
        item = self.stored[-1]
        return (0 if self.static else item.stamp), item.parent

    def at(self, stamp: int) -> tuple[str, Rigid]:
        """The parent and transform at ``stamp`` (0: the newest), or ``_Missing``."""
        if not self.stored:
            raise _Missing("")
        if self.static:
            return self.stored[-1].parent, self.stored[-1].rigid
        if stamp == 0:
            return self.stored[-1].parent, self.stored[-1].rigid
        if len(self.stored) == 1:
            only = self.stored[0]
            if only.stamp == stamp:
                return only.parent, only.rigid
            raise _Missing(
                f"Lookup would require extrapolation at time {_seconds(stamp)}, but only time "
                f"{_seconds(only.stamp)} is in the buffer"
            )
        newest, oldest = self.stored[-1], self.stored[0]
        if stamp > newest.stamp:
            raise _Missing(
                "Lookup would require extrapolation into the future.  Requested time "
                f"{_seconds(stamp)} but the latest data is at time {_seconds(newest.stamp)}"
            )
        if stamp < oldest.stamp:
            raise _Missing(
                "Lookup would require extrapolation into the past.  Requested time "
                f"{_seconds(stamp)} but the earliest data is at time {_seconds(oldest.stamp)}"
            )
        after = bisect.bisect_left([s.stamp for s in self.stored], stamp)
        two = self.stored[after]
        if two.stamp == stamp:
            return two.parent, two.rigid
        one = self.stored[after - 1]
        if one.parent != two.parent:
            return one.parent, one.rigid
        return one.parent, _interpolate(one, two, stamp)


def _nanoseconds(time: Time | int) -> int:
    return time if isinstance(time, int) else time.nanoseconds


class BufferCore:
    """tf2's buffer core: transforms by child frame over time, and lookups between frames."""

    def __init__(self, cache_time: Duration | None = None) -> None:
        self._cache_ns = (cache_time or DEFAULT_CACHE_TIME).nanoseconds
        self._links: dict[str, _Link] = {}
        self._authority: dict[str, str] = {}
        self._lock = threading.RLock()
        self._changed = threading.Condition(self._lock)

    # -- filling it -------------------------------------------------------------------

    def set_transform(self, transform: TransformStamped, authority: str) -> bool:
        """Add a transform that holds at its stamp; ``False`` if it was ignored."""
        return self._set(transform, authority, static=False)

    def set_transform_static(self, transform: TransformStamped, authority: str) -> bool:
        """Add a transform that holds at every time."""
        return self._set(transform, authority, static=True)

    def _set(self, transform: TransformStamped, authority: str, static: bool) -> bool:
        """Store a transform; a bad one is logged with tf2's words and ignored (``False``)."""
        child = transform.child_frame_id.lstrip("/")
        parent = transform.header.frame_id.lstrip("/")
        r, t = transform.transform.rotation, transform.transform.translation
        problems = []
        if child == parent:
            problems.append(
                f'TF_SELF_TRANSFORM: Ignoring transform from authority "{authority}" with '
                f'frame_id and  child_frame_id "{child}" because they are the same'
            )
        if not child:
            problems.append(
                f'TF_NO_CHILD_FRAME_ID: Ignoring transform from authority "{authority}" because '
                "child_frame_id not set "
            )
        if not parent:
            problems.append(
                f'TF_NO_FRAME_ID: Ignoring transform with child_frame_id "{child}"  from '
                f'authority "{authority}" because frame_id not set'
            )
        if any(math.isnan(v) for v in (t.x, t.y, t.z, r.x, r.y, r.z, r.w)):
            problems.append(
                f'TF_NAN_INPUT: Ignoring transform for child_frame_id "{child}" from authority '
                f'"{authority}" because of a nan value in the transform ({t.x:f} {t.y:f} '
                f"{t.z:f}) ({r.x:f} {r.y:f} {r.z:f} {r.w:f})"
            )
        if not abs(r.x**2 + r.y**2 + r.z**2 + r.w**2 - 1.0) < QUATERNION_TOLERANCE:
            problems.append(
                f'TF_DENORMALIZED_QUATERNION: Ignoring transform for child_frame_id "{child}" '
                f'from authority "{authority}" because of an invalid quaternion in the '
                f"transform ({r.x:f} {r.y:f} {r.z:f} {r.w:f})"
            )
        for problem in problems:
            _LOGGER.error(problem)
        if problems:
            return False
        stamp = Time.from_msg(transform.header.stamp).nanoseconds
        rigid = Rigid((r.x, r.y, r.z, r.w), (t.x, t.y, t.z))
        with self._changed:
            link = self._links.get(child)
            if link is None or link.static != static:
                link = self._links[child] = _Link(self._cache_ns, static)
            stored = link.insert(_Stored(stamp, parent, rigid))
            if stored:
                self._authority[child] = authority
            self._changed.notify_all()
        if not stored:
            _LOGGER.warning(
                f"TF_OLD_DATA ignoring data from the past for frame {child} at time "
                f"{_seconds(stamp)} according to authority {authority}\nPossible reasons are "
                "listed at http://wiki.ros.org/tf/Errors%20explained"
            )
        return stored

    def clear(self) -> None:
        """Forget every non-static transform."""
        with self._lock:
            for link in self._links.values():
                if not link.static:
                    link.stored.clear()

    # -- reading it -------------------------------------------------------------------

    def all_frames_as_string(self) -> str:
        """One line a frame: ``Frame CHILD exists with parent PARENT.`` (tf2's words)."""
        with self._lock:
            return "".join(
                f"Frame {child} exists with parent {link.stored[-1].parent}.\n"
                for child, link in self._links.items()
                if link.stored
            )

    def _frames(self) -> set[str]:
        known = set(self._links)
        for link in self._links.values():
            known.update(s.parent for s in link.stored)
        return known

    def _validate(self, function: str, frame: str) -> None:
        """tf2's ``validateFrameId`` for a lookup: raises with its words."""
        if not frame:
            raise InvalidArgumentException(
                f'Invalid argument "{frame}" passed to {function} - in tf2 frame_ids cannot be '
                "empty"
            )
        if frame.startswith("/"):
            raise InvalidArgumentException(
                f'Invalid argument "{frame}" passed to {function} - in tf2 frame_ids cannot '
                "start with a '/'"
            )
        if frame not in self._frames():
            raise LookupException(f'"{frame}" passed to {function} does not exist. ')

    def _parent_chain(self, frame: str) -> list[tuple[str, int, str]]:
        """(child, newest stamp or 0, parent) from ``frame`` up to its root."""
        chain = []
        while frame in self._links and self._links[frame].stored and len(chain) <= MAX_GRAPH_DEPTH:
            stamp, parent = self._links[frame].latest()
            chain.append((frame, stamp, parent))
            frame = parent
        return chain

    def _loop_error(self) -> str:
        return "The tf tree is invalid because it contains a loop.\n" + (
            self.all_frames_as_string() + "\n"
        )

    def _connectivity(self, target: str, source: str) -> ConnectivityException:
        return ConnectivityException(
            f"Could not find a connection between '{target}' and '{source}' because they are "
            "not part of the same tree.Tf has two or more unconnected trees."
        )

    def _latest_common_time(self, target: str, source: str) -> int:
        """The newest time at which every link between the two frames has data (0: static)."""
        up_source = self._parent_chain(source)
        up_target = self._parent_chain(target)
        if len(up_source) > MAX_GRAPH_DEPTH or len(up_target) > MAX_GRAPH_DEPTH:
            raise LookupException(self._loop_error())
        source_path = [source] + [parent for _, _, parent in up_source]
        target_path = [target] + [parent for _, _, parent in up_target]
        common = next((frame for frame in target_path if frame in source_path), None)
        if common is None:
            raise self._connectivity(target, source)
        stamps = [s for child, s, _ in up_source[: source_path.index(common)]]
        stamps += [s for child, s, _ in up_target[: target_path.index(common)]]
        stamps = [s for s in stamps if s != 0]
        return min(stamps) if stamps else 0

    def _walk(self, target: str, source: str, stamp: int) -> Rigid:
        """The transform taking points in ``source`` to ``target`` at ``stamp``."""
        up_from_source: list[str] = [source]
        source_to_frame: dict[str, Rigid] = {source: Rigid()}
        frame, accumulated = source, Rigid()
        missing: str | None = None
        while frame in self._links:
            try:
                parent, rigid = self._links[frame].at(stamp)
            except _Missing as error:
                missing = error.message
                break
            accumulated = rigid * accumulated
            frame = parent
            if frame in source_to_frame or len(up_from_source) > MAX_GRAPH_DEPTH:
                raise LookupException(self._loop_error())
            up_from_source.append(frame)
            source_to_frame[frame] = accumulated
        # from the target up, until a frame of the source's chain
        frame, accumulated, depth = target, Rigid(), 0
        while frame not in source_to_frame:
            link = self._links.get(frame)
            if link is None:
                break
            try:
                parent, rigid = link.at(stamp)
            except _Missing as error:
                raise ExtrapolationException(
                    f"{error.message}, when looking up transform from frame [{source}] to frame "
                    f"[{target}]"
                ) from None
            accumulated = rigid * accumulated
            frame = parent
            depth += 1
            if depth > MAX_GRAPH_DEPTH:
                raise LookupException(self._loop_error())
        if frame not in source_to_frame:
            if missing is not None:
                raise ExtrapolationException(
                    f"{missing}, when looking up transform from frame [{source}] to frame "
                    f"[{target}]"
                )
            raise self._connectivity(target, source)
        # target -> common is `accumulated`, source -> common is source_to_frame[frame]
        return accumulated.inverse() * source_to_frame[frame]

    def lookup_transform_core(
        self, target_frame: str, source_frame: str, time: Time
    ) -> TransformStamped:
        """The transform from ``source_frame`` to ``target_frame`` at ``time`` (0: the
        latest common time), or the error tf2 raises."""
        stamp = _nanoseconds(time)
        with self._lock:
            if target_frame == source_frame:
                rigid = Rigid()
                if stamp == 0 and target_frame in self._links and self._links[target_frame].stored:
                    stamp = self._links[target_frame].latest()[0]
            else:
                self._validate("lookupTransform argument target_frame", target_frame)
                self._validate("lookupTransform argument source_frame", source_frame)
                if stamp == 0:
                    stamp = self._latest_common_time(target_frame, source_frame)
                rigid = self._walk(target_frame, source_frame, stamp)
        return _stamped(rigid, target_frame, source_frame, Time(nanoseconds=stamp).to_msg())

    def lookup_transform_full_core(
        self,
        target_frame: str,
        target_time: Time,
        source_frame: str,
        source_time: Time,
        fixed_frame: str,
    ) -> TransformStamped:
        """Time travel: ``source_frame`` at ``source_time`` into ``target_frame`` at
        ``target_time``, through ``fixed_frame``, which holds still in between."""
        with self._lock:
            for argument, frame in (("target_frame", target_frame),
                                    ("source_frame", source_frame),
                                    ("fixed_frame", fixed_frame)):  # fmt: skip
                self._validate(f"lookupTransform argument {argument}", frame)
            to_fixed = self.lookup_transform_core(fixed_frame, source_frame, source_time)
            from_fixed = self.lookup_transform_core(target_frame, fixed_frame, target_time)
        rigid = _rigid(from_fixed) * _rigid(to_fixed)
        return _stamped(rigid, target_frame, source_frame, from_fixed.header.stamp)

    def can_transform_full_core(
        self,
        target_frame: str,
        target_time: Time,
        source_frame: str,
        source_time: Time,
        fixed_frame: str,
    ) -> tuple[bool, str]:
        """``(True, '')``, or ``(False, why)``, for ``lookup_transform_full_core``."""
        try:
            self.lookup_transform_full_core(
                target_frame, target_time, source_frame, source_time, fixed_frame
            )
        except TransformException as error:
            return False, str(error)
        return True, ""

    def can_transform_core(
        self, target_frame: str, source_frame: str, time: Time
    ) -> tuple[bool, str]:
        """``(True, '')``, or ``(False, why)`` in tf2's words."""
        if target_frame == source_frame:
            return True, ""
        with self._lock:
            for argument, frame in (("target_frame", target_frame),
                                    ("source_frame", source_frame)):  # fmt: skip
                if not frame or frame.startswith("/") or frame not in self._frames():
                    rationale = (
                        "in tf2 frame_ids cannot be empty" if not frame
                        else "in tf2 frame_ids cannot start with a '/'" if frame.startswith("/")
                        else "frame does not exist"
                    )  # fmt: skip
                    return False, (
                        f'Invalid frame ID "{frame}" passed to canTransform argument '
                        f"{argument} - {rationale}"
                    )
            try:
                self.lookup_transform_core(target_frame, source_frame, time)
            except TransformException as error:
                return False, str(error)
        return True, ""

    def _wait(self, ready: Callable[[], bool], timeout: Duration) -> bool:
        """Until ``ready()``, or ``timeout`` of the wall clock (as tf2_ros waits)."""
        deadline = _time.monotonic() + timeout.nanoseconds / 1e9
        with self._changed:
            while not ready():
                left = deadline - _time.monotonic()
                if left <= 0:
                    return False
                self._changed.wait(left)
        return True


class Buffer(BufferCore):
    """tf2_ros's ``Buffer``: a buffer core with lookups that can wait for their transform.

    Filled by a ``TransformListener`` (or ``set_transform``). A wait (``timeout``) returns
    as soon as the transform can be computed; something else must spin the listener's node
    meanwhile (``TransformListener(..., spin_thread=True)``, or another thread), as with
    tf2_ros. When the clock (``node``'s, else the system's) jumps back in time by more
    than a second, as simulated time does when a simulation restarts, the buffer forgets
    its transforms, as tf2_ros's does.
    """

    def __init__(self, cache_time: Duration | None = None, node: Node | None = None) -> None:
        super().__init__(cache_time)
        self.clock = node.get_clock() if node is not None else Clock()
        self._callbacks: list[Callable[[], None]] = []
        threshold = JumpThreshold(
            min_forward=None, min_backward=Duration(seconds=-1), on_clock_change=True
        )
        self.jump_handle = self.clock.create_jump_callback(
            threshold, post_callback=self.time_jump_callback
        )

    def time_jump_callback(self, time_jump: object) -> None:
        """Forget the transforms: they belong to a time that is gone."""
        rclpy.logging.get_logger("tf2_buffer").warning(
            "Detected jump back in time. Clearing tf buffer."
        )
        self.clear()

    def set_transform(self, transform: TransformStamped, authority: str) -> bool:
        stored = super().set_transform(transform, authority)
        self._notify()
        return stored

    def set_transform_static(self, transform: TransformStamped, authority: str) -> bool:
        stored = super().set_transform_static(transform, authority)
        self._notify()
        return stored

    def _notify(self) -> None:
        for callback in list(self._callbacks):
            callback()

    def lookup_transform(
        self,
        target_frame: str,
        source_frame: str,
        time: Time,
        timeout: Duration = NO_WAIT,
    ) -> TransformStamped:
        """The transform from ``source_frame`` to ``target_frame`` at ``time`` (``Time()``:
        the latest), waiting up to ``timeout`` for it; tf2's exception if it cannot be had."""
        self.can_transform(target_frame, source_frame, time, timeout)
        return self.lookup_transform_core(target_frame, source_frame, time)

    def can_transform(
        self,
        target_frame: str,
        source_frame: str,
        time: Time,
        timeout: Duration = NO_WAIT,
        return_debug_tuple: bool = False,
    ) -> bool | tuple[bool, str]:
        """Whether the transform can be had, waiting up to ``timeout`` for it."""
        return self._answer(
            lambda: self.can_transform_core(target_frame, source_frame, time),
            timeout, return_debug_tuple,
        )  # fmt: skip

    def _answer(
        self, check: Callable[[], tuple[bool, str]], timeout: Duration, debug: bool
    ) -> bool | tuple[bool, str]:
        """``check()``, once it is true or ``timeout`` (wall clock) has passed."""
        if timeout != NO_WAIT:
            self._wait(lambda: check()[0], timeout)
        result = check()
        return result if debug else result[0]

    def lookup_transform_full(
        self,
        target_frame: str,
        target_time: Time,
        source_frame: str,
        source_time: Time,
        fixed_frame: str,
        timeout: Duration = NO_WAIT,
    ) -> TransformStamped:
        """Time travel (see ``lookup_transform_full_core``), waiting up to ``timeout``."""
        self.can_transform_full(
            target_frame, target_time, source_frame, source_time, fixed_frame, timeout
        )
        return self.lookup_transform_full_core(
            target_frame, target_time, source_frame, source_time, fixed_frame
        )

    def can_transform_full(
        self,
        target_frame: str,
        target_time: Time,
        source_frame: str,
        source_time: Time,
        fixed_frame: str,
        timeout: Duration = NO_WAIT,
        return_debug_tuple: bool = False,
    ) -> bool | tuple[bool, str]:
        """Whether ``lookup_transform_full`` can answer, waiting up to ``timeout``."""
        args = (target_frame, target_time, source_frame, source_time, fixed_frame)
        return self._answer(
            lambda: self.can_transform_full_core(*args), timeout, return_debug_tuple
        )

    def wait_for_transform_async(self, target_frame: str, source_frame: str, time: Time):  # noqa: ANN201
        """A future that completes with the transform once it can be had."""
        from rclpy.task import Future

        future: Future = Future()

        def check() -> None:
            if future.done():
                return
            if self.can_transform_core(target_frame, source_frame, time)[0]:
                future.set_result(self.lookup_transform_core(target_frame, source_frame, time))

        check()
        if not future.done():
            self._callbacks.append(check)
            future.add_done_callback(lambda _f: self._callbacks.remove(check))
        return future

    async def lookup_transform_async(
        self, target_frame: str, source_frame: str, time: Time
    ) -> TransformStamped:
        """The transform, awaited until it can be had (in a coroutine callback)."""
        return await self.wait_for_transform_async(target_frame, source_frame, time)


class TransformListener:
    """Fills a ``Buffer`` from ``/tf`` and ``/tf_static`` (tf2_ros's QoS for each)."""

    def __init__(
        self,
        buffer: Buffer,
        node: Node,
        *,
        spin_thread: bool = False,
        qos: QoSProfile | int | None = None,
        static_qos: QoSProfile | int | None = None,
    ) -> None:
        from tf2_msgs.msg import TFMessage

        self.buffer = buffer
        self.node = node
        self.group = ReentrantCallbackGroup()
        self.tf_sub = node.create_subscription(
            TFMessage, "/tf", self.callback, TF_QOS if qos is None else qos,
            callback_group=self.group,
        )  # fmt: skip
        self.tf_static_sub = node.create_subscription(
            TFMessage, "/tf_static", self.static_callback,
            TF_STATIC_LISTENER_QOS if static_qos is None else static_qos,
            callback_group=self.group,
        )  # fmt: skip
        self.executor: SingleThreadedExecutor | None = None
        if spin_thread:
            self.executor = SingleThreadedExecutor(context=node.context)
            self.executor.add_node(node)
            self.dedicated_listener_thread = threading.Thread(
                target=self._spin, name="tf_listener", daemon=True
            )
            self.dedicated_listener_thread.start()

    def _spin(self) -> None:
        assert self.executor is not None
        try:
            self.executor.spin()
        except Exception:  # the context was shut down under it: the thread just ends
            pass

    def unregister(self) -> None:
        """Stop listening: destroys both subscriptions, and the spinning thread if any."""
        if self.executor is not None:
            self.executor.shutdown()
            self.dedicated_listener_thread.join()
            self.executor = None
        self.node.destroy_subscription(self.tf_sub)
        self.node.destroy_subscription(self.tf_static_sub)

    def callback(self, data) -> None:  # noqa: ANN001
        for transform in data.transforms:
            self.buffer.set_transform(transform, "default_authority")

    def static_callback(self, data) -> None:  # noqa: ANN001
        for transform in data.transforms:
            self.buffer.set_transform_static(transform, "default_authority")


def _as_list(transform: TransformStamped | Iterable[TransformStamped]) -> list[TransformStamped]:
    if isinstance(transform, list):
        return transform
    if hasattr(transform, "__iter__"):
        return list(transform)  # type: ignore[arg-type]
    return [transform]  # type: ignore[list-item]


class TransformBroadcaster:
    """Publishes transforms on ``/tf`` (depth 100, volatile)."""

    def __init__(self, node: Node, qos: QoSProfile | int | None = None) -> None:
        from tf2_msgs.msg import TFMessage

        self._message = TFMessage
        self.pub_tf = node.create_publisher(TFMessage, "/tf", QoSProfile(depth=100)
                                            if qos is None else qos)  # fmt: skip

    def sendTransform(  # noqa: N802 (tf2_ros's name)
        self, transform: TransformStamped | Iterable[TransformStamped]
    ) -> None:
        """Publish one transform, or several in one message."""
        self.pub_tf.publish(self._message(transforms=_as_list(transform)))


class StaticTransformBroadcaster:
    """Publishes transforms on ``/tf_static`` (transient local: late listeners get them).

    Every message holds every static transform this broadcaster has sent, one per child
    frame (the first one sent for it), as tf2_ros's does.
    """

    def __init__(self, node: Node, qos: QoSProfile | int | None = None) -> None:
        from tf2_msgs.msg import TFMessage

        self.pub_tf = node.create_publisher(
            TFMessage, "/tf_static", TF_STATIC_BROADCASTER_QOS if qos is None else qos
        )
        self.net_message = TFMessage()
        self._child_frame_ids: set[str] = set()

    def sendTransform(  # noqa: N802 (tf2_ros's name)
        self, transform: TransformStamped | Iterable[TransformStamped]
    ) -> None:
        """Add transforms for new child frames, and publish them all."""
        for item in _as_list(transform):
            if item.child_frame_id not in self._child_frame_ids:
                self._child_frame_ids.add(item.child_frame_id)
                self.net_message.transforms.append(item)
        self.pub_tf.publish(self.net_message)
