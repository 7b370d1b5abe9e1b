"""Quality of Service, measured: the KEEP_LAST model, the delivery scenarios over real DDS,
and the compatibility rules with the events that reveal a mismatch.

Three things live here, shared by the QoS chapter, lab 2 and its checks:

* :func:`model_records` / :func:`predict_processed`: the idealised KEEP_LAST queue (the
  algorithm lab 2 asks for, in exact arithmetic), the reference for everything measured.
* :func:`run_delivery` / :func:`run_late_joiner`: a real publisher and a real subscriber
  over DDS, on a simulated clock (or on wall time), recording for every message when it
  was published, taken by the callback, processed, or dropped.
* :func:`incompatible_policies`, :func:`rclpy_incompatible_policies` and
  :func:`watch_incompatibility`: which policies stop a pair from connecting, by the rules,
  by rclpy's own check, and by the events both endpoints raise.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.duration import Duration
from rclpy.event_handler import (
    PublisherEventCallbacks,
    QoSOfferedIncompatibleQoSInfo,
    QoSRequestedIncompatibleQoSInfo,
    SubscriptionEventCallbacks,
)
from rclpy.node import Node
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSCompatibility,
    QoSPolicyKind,
    QoSProfile,
    ReliabilityPolicy,
    qos_check_compatible,
)
from std_msgs.msg import String

from rosbook.runtime.clock import LockstepClock
from rosbook.runtime.clock import now_ns as _now_ns
from rosbook.runtime.executors import MultiThreadedExecutor, SingleThreadedExecutor
from rosbook.runtime.session import Session, notebook_session

#: The policies whose mismatch stops a publisher and a subscription from connecting
#: (liveliness can too; the book leaves it at the defaults).
POLICIES: tuple[str, ...] = ("reliability", "durability", "deadline")

# -- the idealised KEEP_LAST model ------------------------------------------------------


@dataclass
class MessageRecord:
    """What happened to one message; times in seconds since the first publish.

    ``received`` is when the subscriber's callback took it from the queue (and started
    on it), ``processed`` when that callback returned, ``dropped`` when it left a queue
    without ever being taken (evicted by a newer message, or sent to nobody).
    """

    index: int
    published: float
    received: float | None = None
    processed: float | None = None
    dropped: float | None = None

    @property
    def outcome(self) -> str:
        if self.processed is not None:
            return "processed"
        if self.received is not None:
            return "in progress"
        if self.dropped is not None:
            return "dropped"
        return "waiting"

    @property
    def latency(self) -> float | None:
        """Seconds from publish until the callback started on it."""
        return None if self.received is None else self.received - self.published


def _exact(value: float) -> Fraction:
    """``0.1`` as 1/10, not as the binary float nearest to it: ties stay ties."""
    return Fraction(repr(float(value)))


def publish_times(publish_hz: float, duration_s: float) -> list[Fraction]:
    """t = 0, 1/hz, 2/hz, ... while t < duration_s (exact)."""
    hz, duration = _exact(publish_hz), _exact(duration_s)
    if hz <= 0:
        raise ValueError("publish_hz must be positive")
    count = max(0, math.ceil(duration * hz))
    return [Fraction(k) / hz for k in range(count)]


def model_records(
    publish_hz: float, callback_s: float, depth: int, duration_s: float
) -> list[MessageRecord]:
    """Every message's fate under the idealised KEEP_LAST model.

    Messages arrive when they are published; one that arrives while the callback is idle
    starts at once; otherwise it waits in a queue of at most ``depth`` messages, and a
    full queue drops its oldest. A finish and an arrival at the same instant: the finish
    comes first. After the last publish the subscriber drains its queue.
    """
    if depth < 1:
        raise ValueError("a KEEP_LAST queue holds at least one message (depth >= 1)")
    work = _exact(callback_s)
    times = publish_times(publish_hz, duration_s)
    exact: list[dict[str, Fraction | None]] = [
        {"published": t, "received": None, "processed": None, "dropped": None} for t in times
    ]
    queue: deque[int] = deque()
    busy_until: Fraction | None = None

    def start(i: int, t: Fraction) -> Fraction:
        exact[i]["received"] = t
        exact[i]["processed"] = t + work
        return t + work

    def finish_up_to(t: Fraction | None) -> Fraction | None:
        """Run the finishes due by ``t`` (all of them when ``t`` is None)."""
        nonlocal busy_until
        while busy_until is not None and (t is None or busy_until <= t):
            done = busy_until
            busy_until = start(queue.popleft(), done) if queue else None
        return busy_until

    for i, t in enumerate(times):
        finish_up_to(t)
        if busy_until is None:
            busy_until = start(i, t)
            continue
        if len(queue) == depth:
            exact[queue.popleft()]["dropped"] = t
        queue.append(i)
    finish_up_to(None)
    return [
        MessageRecord(
            index=i + 1,
            **{k: None if v is None else float(v) for k, v in fields.items()},  # type: ignore[arg-type]
        )
        for i, fields in enumerate(exact)
    ]


def predict_processed(
    publish_hz: float, callback_s: float, depth: int, duration_s: float
) -> list[int]:
    """The 1-based indices of the messages a KEEP_LAST subscriber processes, in order."""
    records = model_records(publish_hz, callback_s, depth, duration_s)
    started = sorted((r for r in records if r.received is not None), key=lambda r: r.received)
    return [r.index for r in started]


# -- tables -----------------------------------------------------------------------------


def processed_indices(records: Sequence[MessageRecord]) -> list[int]:
    """The indices of the messages the callback started on, in the order it did."""
    started = [r for r in records if r.received is not None]
    return [r.index for r in sorted(started, key=lambda r: (r.received, r.index))]


def dropped_indices(records: Sequence[MessageRecord]) -> list[int]:
    return [r.index for r in records if r.dropped is not None]


def queue_after_arrivals(records: Sequence[MessageRecord]) -> list[tuple[float, int]]:
    """(time, messages waiting) right after each arrival, the arriving one included."""
    out = []
    for arrival in records:
        t = arrival.published
        waiting = sum(
            1
            for r in records
            if r.published <= t
            and (r.received is None or r.received >= t)
            and (r.dropped is None or r.dropped > t)
        )
        out.append((t, waiting))
    return out


def max_queue(records: Sequence[MessageRecord]) -> int:
    return max((n for _, n in queue_after_arrivals(records)), default=0)


def _cell(value: float | None, decimals: int) -> str:
    return "" if value is None else f"{value:.{decimals}f}"


def table_rows(records: Sequence[MessageRecord], decimals: int = 1) -> list[tuple[str, ...]]:
    """One row per message: msg, published, taken, processed, dropped, latency (seconds)."""
    return [
        (
            f"msg{r.index}",
            _cell(r.published, decimals),
            _cell(r.received, decimals),
            _cell(r.processed, decimals),
            _cell(r.dropped, decimals),
            _cell(r.latency, decimals),
        )
        for r in records
    ]


TABLE_HEADER = ("message", "published", "taken", "processed", "dropped", "waited")


def table_markdown(records: Sequence[MessageRecord], decimals: int = 1) -> str:
    """The delivery table as Markdown (times in seconds since the first publish)."""
    lines = [
        "| " + " | ".join(TABLE_HEADER) + " |",
        "|" + "---|" * len(TABLE_HEADER),
    ]
    for row in table_rows(records, decimals):
        lines.append("| " + " | ".join(cell or "–" for cell in row) + " |")
    return "\n".join(lines)


def table_html(records: Sequence[MessageRecord], decimals: int = 1) -> str:
    """The delivery table as an HTML table (what a built page shows)."""
    head = "".join(f"<th>{h}</th>" for h in TABLE_HEADER)
    body = "".join(
        "<tr>" + "".join(f"<td>{cell or '–'}</td>" for cell in row) + "</tr>"
        for row in table_rows(records, decimals)
    )
    return f'<table class="qos-table"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def until(records: Sequence[MessageRecord], horizon: float) -> list[MessageRecord]:
    """The records as they stood at ``horizon`` (events after it not yet happened)."""

    def cut(v: float | None) -> float | None:
        return v if v is not None and v <= horizon + 1e-9 else None

    return [
        replace(r, received=cut(r.received), processed=cut(r.processed), dropped=cut(r.dropped))
        for r in records
        if r.published <= horizon + 1e-9
    ]


def timeline_differences(
    measured: Sequence[MessageRecord], expected: Sequence[MessageRecord], tol: float = 1e-6
) -> list[str]:
    """How ``measured`` differs from ``expected``: one line per disagreement (empty: same)."""
    problems = []
    if len(measured) != len(expected):
        problems.append(f"{len(measured)} messages measured, {len(expected)} expected")
    for m, e in zip(measured, expected):
        for name in ("published", "received", "processed", "dropped"):
            a, b = getattr(m, name), getattr(e, name)
            if (a is None) != (b is None) or (a is not None and abs(a - b) > tol):
                problems.append(f"msg{m.index}.{name}: measured {a}, expected {b}")
    return problems


def impossible_events(records: Sequence[MessageRecord], callback_s: float) -> list[str]:
    """What a run of one subscriber whose callback works ``callback_s`` could never show,
    whatever the machine's load (empty: nothing): msg1 not the first message taken,
    messages taken out of publishing order, a message worked on for less than
    ``callback_s``, or two worked on at the same time.

    A load only delays events: on wall time, which messages are processed and when
    depends on it; these hold for every run.
    """
    problems = []
    taken = sorted((r for r in records if r.received is not None), key=lambda r: r.received)
    if records and (not taken or taken[0].index != 1):
        problems.append("msg1 was not the first message taken")
    indices = [r.index for r in taken]
    if indices != sorted(indices):
        problems.append(f"messages taken out of order: {indices}")
    for r in taken:
        if r.processed is not None and r.processed - r.received < callback_s - 1e-6:
            problems.append(
                f"msg{r.index} was processed in {r.processed - r.received:.3f} s, "
                f"less than the callback's {callback_s:g} s"
            )
    for before, after in zip(taken, taken[1:]):
        if before.processed is None or after.received < before.processed - 1e-6:
            problems.append(f"msg{after.index} was taken while msg{before.index} was worked on")
    return problems


def plot_timeline(records: Sequence[MessageRecord], title: str, ax: Any = None) -> Any:
    """Published / taken / processed / dropped markers per message over time."""
    import matplotlib.pyplot as plt

    if ax is None:
        # At most the book column's width (about 7 in at 100 dpi): shown unshrunk, its
        # 10 pt text is 10 px or more on a 1280 px screen.
        _, ax = plt.subplots(figsize=(7, 0.32 * max(len(records), 4) + 1.6))
    for r in records:
        end = r.processed if r.processed is not None else r.dropped
        if r.received is not None:
            ax.plot([r.published, r.received], [r.index] * 2, color="0.7", lw=1.5, zorder=1)
            ax.plot([r.received, end], [r.index] * 2, color="tab:green", lw=4, zorder=1)
        elif end is not None:
            ax.plot([r.published, end], [r.index] * 2, color="0.7", lw=1.5, ls=":", zorder=1)
    kinds = [
        ("published", "o", "tab:blue", "published"),
        ("received", ">", "tab:green", "taken by the callback"),
        ("processed", "s", "tab:olive", "processed (callback returned)"),
        ("dropped", "X", "tab:red", "dropped"),
    ]
    for name, marker, colour, label in kinds:
        points = [(getattr(r, name), r.index) for r in records if getattr(r, name) is not None]
        if points:
            xs, ys = zip(*points)
            ax.scatter(xs, ys, marker=marker, color=colour, label=label, zorder=2, s=40)
    ax.set_yticks([r.index for r in records], [f"msg{r.index}" for r in records])
    if records:  # first message on top (set, not toggled: axes may share y)
        ax.set_ylim(max(r.index for r in records) + 0.5, min(r.index for r in records) - 0.5)
    ax.set_xlabel("time since the first publish (s)")
    ax.set_title(title)
    ax.grid(axis="x", alpha=0.3)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.3), ncols=2, fontsize=10)
    ax.figure.tight_layout()
    return ax


# -- the scenario nodes -----------------------------------------------------------------


def delivery_qos(depth: int = 3, durability: DurabilityPolicy | None = None) -> QoSProfile:
    """RELIABLE, KEEP_LAST ``depth``: the QoS of both ends in the delivery scenarios."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=durability or DurabilityPolicy.VOLATILE,
    )


class CountingPublisher(Node):
    """Publishes ``'1'``, ``'2'``, ... on ``topic`` at ``publish_hz``, ``count`` messages,
    and remembers on its own clock when it published each one."""

    def __init__(
        self, topic: str, qos: QoSProfile, publish_hz: float, count: int, name: str = "publisher"
    ) -> None:
        super().__init__(name)
        self.publisher_ = self.create_publisher(String, topic, qos)
        self.count = count
        self.period_ns = int(round(1e9 / publish_hz))
        self.sent_ns: list[int] = []
        self.timer = self.create_timer(self.period_ns / 1e9, self.timer_callback)

    def timer_callback(self) -> None:
        if len(self.sent_ns) >= self.count:
            self.timer.cancel()
            return
        now = _now_ns(self)
        self.publisher_.publish(String(data=str(len(self.sent_ns) + 1)))
        self.sent_ns.append(now)  # after publish: a reader of sent_ns knows it is sent
        if len(self.sent_ns) >= self.count:
            self.timer.cancel()

    def expected_by(self, now_ns: int) -> int:
        """How many messages its timer (made at t = 0) has sent by ``now_ns``."""
        return min(self.count, now_ns // self.period_ns)


class WorkingSubscriber(Node):
    """Takes messages from ``topic`` and works ``callback_s`` seconds of its clock on each.

    The work is ``self.get_clock().sleep_until(...)``: on wall time a plain sleep, on
    simulated time a wait until ``/clock`` has moved on by that much. The subscription has
    a callback group of its own, so while the callback works the node's clock (its
    ``/clock`` subscription) still runs in a second thread of a multi-threaded executor;
    the subscription itself is never taken twice at once, and the messages that arrive
    meanwhile wait in the DDS reader's KEEP_LAST history.
    """

    def __init__(
        self, topic: str, qos: QoSProfile, callback_s: float, name: str = "subscriber"
    ) -> None:
        super().__init__(name)
        self.work = Duration(nanoseconds=int(round(callback_s * 1e9)))
        self.taken: list[tuple[int, int]] = []
        self.finished: list[tuple[int, int]] = []
        self.busy_until: int | None = None
        self.stopping = False
        self.subscription = self.create_subscription(
            String,
            topic,
            self.listener_callback,
            qos,
            callback_group=MutuallyExclusiveCallbackGroup(),
        )

    def listener_callback(self, msg: String) -> None:
        if self.stopping:
            return
        start = self.get_clock().now()
        self.busy_until = (start + self.work).nanoseconds
        self.taken.append((int(msg.data), start.nanoseconds))
        if self.get_clock().sleep_until(start + self.work) and not self.stopping:
            self.finished.append((int(msg.data), _now_ns(self)))
        self.busy_until = None


class LateJoiner(Node):
    """A subscriber that joins late; remembers what it still gets, and when."""

    def __init__(self, name: str = "late_joiner") -> None:
        super().__init__(name)
        self.got: list[tuple[int, int]] = []

    def join(self, topic: str, qos: QoSProfile) -> None:
        """Subscribe now (once the node's clock reads the joining time)."""
        self.subscription = self.create_subscription(String, topic, self.listener_callback, qos)

    def listener_callback(self, msg: String) -> None:
        self.got.append((int(msg.data), _now_ns(self)))


# -- driving them -----------------------------------------------------------------------


def wait_until(condition: Callable[[], bool], timeout: float, poll: float = 0.0002) -> bool:
    """Wait (spinning nothing: other threads do) until ``condition()``; whether it held."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(poll)
    return True


class Spinner:
    """An executor spinning some nodes in a background thread until stopped.

    The nodes it spins are its own while it runs: nothing else (``ros.spin_*``, another
    executor) may spin them meanwhile. The session's bookkeeping is locked, so a
    callback here may still create or destroy nodes.
    """

    def __init__(self, executor: SingleThreadedExecutor | MultiThreadedExecutor) -> None:
        self.executor = executor
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            self.executor.spin_once(timeout_sec=0.01)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5.0)
        _close(self.executor)


def _close(executor: SingleThreadedExecutor | MultiThreadedExecutor) -> None:
    """Shut ``executor`` down and let go of its nodes."""
    executor.shutdown(timeout_sec=5.0)
    for node in list(executor.get_nodes()):
        executor.remove_node(node)


@dataclass
class ScenarioRun:
    """A measured scenario: its records, and what the run cost and covered."""

    name: str
    records: list[MessageRecord]
    clock: str
    wall_s: float
    simulated_s: float

    @property
    def processed(self) -> list[int]:
        return processed_indices(self.records)

    @property
    def dropped(self) -> list[int]:
        return dropped_indices(self.records)

    def table(self, decimals: int = 1) -> str:
        return table_markdown(self.records, decimals)


def _records_from(
    sent_ns: Sequence[int],
    taken: Sequence[tuple[int, int]],
    finished: Sequence[tuple[int, int]],
    origin_ns: int,
    depth: int,
) -> list[MessageRecord]:
    """Records from what the nodes measured, plus the date of each drop.

    DDS does not report when KEEP_LAST overwrites a sample nobody took. While a message
    waits, every newer one queues behind it (the callback takes the oldest first), so the
    arrival that overflowed the queue and evicted it is the ``depth``-th newer message:
    its measured publish time is the drop's date.
    """

    def s(ns: int) -> float:
        return round((ns - origin_ns) / 1e9, 9)

    records = [MessageRecord(i + 1, s(t)) for i, t in enumerate(sent_ns)]
    for index, t in taken:
        records[index - 1].received = s(t)
    for index, t in finished:
        records[index - 1].processed = s(t)
    for r in records:
        if r.received is None and r.index + depth <= len(records):
            r.dropped = records[r.index + depth - 1].published
    return records


def _settled(sub: WorkingSubscriber, pub: CountingPublisher, now_ns: int) -> bool:
    """The subscriber has reacted to everything up to ``now_ns``.

    Busy: its callback works until a later time. Idle: it has taken the newest message
    published (messages are taken oldest first, so nothing else waits).
    """
    busy_until = sub.busy_until
    if busy_until is not None:
        return busy_until > now_ns
    return not pub.sent_ns or (bool(sub.taken) and sub.taken[-1][0] == len(pub.sent_ns))


def run_delivery(
    callback_s: float,
    *,
    publish_hz: float = 2.0,
    depth: int = 3,
    duration_s: float = 6.0,
    sim_time: bool = True,
    horizon_s: float | None = None,
    max_step_s: float = 0.5,
    topic: str = "counter",
    session: Session | None = None,
) -> ScenarioRun:
    """A publisher at ``publish_hz`` and a subscriber whose callback takes ``callback_s``.

    Both ends use RELIABLE, VOLATILE, KEEP_LAST ``depth``; each is spun by its own
    executor, as if they were two processes. The publisher sends while
    t < ``duration_s``; the run then lets the subscriber drain its queue, or stops
    ``horizon_s`` after the first publish. On ``sim_time`` the run's ``/clock`` moves from
    event to event (a publish, a callback's end; at most ``max_step_s``); at each step the
    subscriber reacts first, then the run spins the publisher (``_drive``). On wall time
    both run in threads of their own. Resets the session.
    """
    ros = notebook_session(session)
    count = len(publish_times(publish_hz, duration_s))
    qos = delivery_qos(depth)
    wall0 = time.monotonic()
    if sim_time:
        clock: LockstepClock | None = ros.sim_clock().clock
    else:
        ros.init()
        ros.reset()
        clock = None
    pub = CountingPublisher(topic, qos, publish_hz, count)
    sub = WorkingSubscriber(topic, qos, callback_s)
    if not ros.spin_until(lambda: pub.publisher_.get_subscription_count() > 0, pub, timeout=5):
        raise TimeoutError("the subscriber never matched the publisher")
    pub_exec = SingleThreadedExecutor()
    pub_exec.add_node(pub)
    sub_exec = MultiThreadedExecutor(num_threads=2)
    sub_exec.add_node(sub)
    # On simulated time the run itself spins the publisher, in step with the clock
    # (see _drive); on wall time both run freely.
    spinners = [Spinner(sub_exec)] + ([Spinner(pub_exec)] if clock is None else [])
    try:
        if clock is not None:
            _drive(clock, pub_exec, pub, sub, horizon_s, int(round(max_step_s * 1e9)))
        else:
            _run_wall(pub, sub, horizon_s)
        origin = pub.sent_ns[0]
        records = _records_from(pub.sent_ns, list(sub.taken), list(sub.finished), origin, depth)
        end_ns = (clock.now_ns if clock else _now_ns(pub)) - origin
    finally:
        sub.stopping = True
        if clock is not None:  # wake a callback that still works (stopped at a horizon)
            clock.set(clock.now_ns + 1_000_000_000_000, [sub])
        for spinner in spinners:
            spinner.stop()
        if clock is not None:
            _close(pub_exec)
        ros.reset()
    if horizon_s is not None:
        records = until(records, horizon_s)
    name = f"{publish_hz:g} Hz, callback {callback_s:g} s, depth {depth}"
    clock_name = "sim" if sim_time else "wall"
    return ScenarioRun(name, records, clock_name, time.monotonic() - wall0, end_ns / 1e9)


def _drive(
    clock: LockstepClock,
    pub_exec: SingleThreadedExecutor,
    pub: CountingPublisher,
    sub: WorkingSubscriber,
    horizon_s: float | None,
    max_step_ns: int,
    timeout: float = 5.0,
) -> None:
    """Move ``/clock`` from event to event until the subscriber has drained (or horizon).

    Each step first lets the subscriber follow the clock and react (a callback ends and
    the next queued message is taken), and only then spins the publisher until its
    timer has fired: its message can never reach a subscriber whose clock still reads
    the previous step, and a callback that ends at the instant of a publish ends first.
    """

    def settled() -> bool:
        return _settled(sub, pub, clock.now_ns)

    def published() -> bool:
        return _now_ns(pub) >= clock.now_ns and len(pub.sent_ns) >= pub.expected_by(clock.now_ns)

    horizon_ns: int | None = None
    now_ns = 0
    while True:
        clock.set(now_ns, [sub])
        if not wait_until(settled, timeout):
            raise TimeoutError(f"the subscriber did not react at t = {now_ns / 1e9:.3f} s")
        start = time.monotonic()
        while not published():
            waited = time.monotonic() - start
            if waited > timeout:
                raise TimeoutError(f"the publisher did not publish at t = {now_ns / 1e9:.3f} s")
            if waited > 0.05 and _now_ns(pub) < now_ns:
                clock.publish()  # the publisher missed it
            pub_exec.spin_once(timeout_sec=0.01)
        if not wait_until(settled, timeout):
            raise TimeoutError(f"the subscriber did not react at t = {now_ns / 1e9:.3f} s")
        if pub.sent_ns and horizon_s is not None and horizon_ns is None:
            horizon_ns = pub.sent_ns[0] + int(round(horizon_s * 1e9))
        drained = len(pub.sent_ns) >= pub.count and sub.busy_until is None
        if drained or (horizon_ns is not None and now_ns >= horizon_ns):
            return
        candidates = [now_ns + max_step_ns]
        if len(pub.sent_ns) < pub.count:
            candidates.append((len(pub.sent_ns) + 1) * pub.period_ns)
        if sub.busy_until is not None:
            candidates.append(sub.busy_until)
        if horizon_ns is not None:
            candidates.append(horizon_ns)
        now_ns = min(candidates)


def _run_wall(pub: CountingPublisher, sub: WorkingSubscriber, horizon_s: float | None) -> None:
    """Let both run on wall time until everything is processed (or the horizon)."""
    wait_until(lambda: bool(pub.sent_ns), timeout=5.0, poll=0.001)
    end = time.monotonic() + (horizon_s if horizon_s is not None else 600.0)
    wait_until(
        lambda: (
            len(pub.sent_ns) >= pub.count
            and sub.busy_until is None
            and bool(sub.taken)
            and sub.taken[-1][0] == pub.count
            or time.monotonic() >= end
        ),
        timeout=end - time.monotonic() + 1.0,
        poll=0.001,
    )


def run_late_joiner(
    durability: DurabilityPolicy,
    *,
    publish_hz: float = 2.0,
    depth: int = 3,
    duration_s: float = 2.0,
    join_s: float = 2.5,
    topic: str = "counter",
    settle_s: float = 0.3,
    joiner_durability: DurabilityPolicy | None = None,
    session: Session | None = None,
) -> ScenarioRun:
    """No subscriber while the publisher sends; a subscriber joins at ``join_s``.

    The publisher uses ``durability``, the late joiner ``joiner_durability`` (default:
    the same). Messages the late joiner never gets are dropped: when both ends are
    TRANSIENT_LOCAL, at the publish that pushed them out of the publisher's KEEP_LAST
    history of ``depth``; otherwise at their publish (nobody there to deliver to).
    """
    count = len(publish_times(publish_hz, duration_s))
    qos = delivery_qos(depth, durability)
    joiner_qos = delivery_qos(depth, joiner_durability or durability)
    wall0 = time.monotonic()
    ros = notebook_session(session)
    clock = ros.sim_clock().clock
    pub = CountingPublisher(topic, qos, publish_hz, count)
    pub_exec = SingleThreadedExecutor()
    pub_exec.add_node(pub)
    spinners = [Spinner(pub_exec)]
    try:
        clock.set(0, [pub])
        while len(pub.sent_ns) < count:
            clock.set((len(pub.sent_ns) + 1) * pub.period_ns, [pub])
            if not wait_until(lambda: len(pub.sent_ns) >= pub.expected_by(clock.now_ns), 5.0):
                raise TimeoutError("the publisher did not publish on time")
        origin = pub.sent_ns[0]
        clock.set(origin + int(round(join_s * 1e9)), [pub])
        joiner = LateJoiner()
        joiner_exec = SingleThreadedExecutor()
        joiner_exec.add_node(joiner)
        spinners.append(Spinner(joiner_exec))
        clock.set(clock.now_ns, [pub, joiner])
        joiner.join(topic, joiner_qos)
        matched = wait_until(lambda: joiner.subscription.get_publisher_count() > 0, 5.0)
        if not matched:
            raise TimeoutError("the late joiner never matched the publisher")
        wait_until(lambda: len(joiner.got) >= count, settle_s)
        records = [MessageRecord(i + 1, (t - origin) / 1e9) for i, t in enumerate(pub.sent_ns)]
        for index, t in list(joiner.got):
            records[index - 1].received = (t - origin) / 1e9
            records[index - 1].processed = records[index - 1].received  # instant callback
        kept = joiner_qos.durability == qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
        for r in records:
            if r.received is None:
                overwritten = r.index + depth - 1
                if kept and overwritten < count:
                    r.dropped = records[overwritten].published
                else:
                    r.dropped = r.published
        end_ns = clock.now_ns - origin
    finally:
        for spinner in spinners:
            spinner.stop()
        ros.reset()
    pub_kind, joiner_kind = durability.name, joiner_qos.durability.name
    name = (
        f"{publish_hz:g} Hz, {pub_kind} publisher, {joiner_kind} subscriber joins at {join_s:g} s"
    )
    return ScenarioRun(name, records, "sim", time.monotonic() - wall0, end_ns / 1e9)


# -- compatibility ----------------------------------------------------------------------


def _deadline_ns(qos: QoSProfile) -> int | None:
    """The deadline in ns; None for the default 0, which means "no deadline".

    rmw compares an explicit ``Infinite`` like any other duration: a subscription asking
    for it does not connect to a publisher that set no deadline.
    """
    ns = qos.deadline.nanoseconds
    return None if ns == 0 else ns


def incompatible_policies(pub_qos: QoSProfile, sub_qos: QoSProfile) -> set[str]:
    """The policies among reliability, durability, deadline that stop the pair connecting.

    A subscription may ask for less than the publisher offers, never more: RELIABLE
    from a BEST_EFFORT publisher, TRANSIENT_LOCAL from a VOLATILE one, or a deadline
    shorter than the publisher's (a publisher without one satisfies only a subscription
    without one).
    """
    bad = set()
    if (
        pub_qos.reliability == ReliabilityPolicy.BEST_EFFORT
        and sub_qos.reliability == ReliabilityPolicy.RELIABLE
    ):
        bad.add("reliability")
    if (
        pub_qos.durability == DurabilityPolicy.VOLATILE
        and sub_qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
    ):
        bad.add("durability")
    pub_deadline, sub_deadline = _deadline_ns(pub_qos), _deadline_ns(sub_qos)
    if sub_deadline is not None and (pub_deadline is None or pub_deadline > sub_deadline):
        bad.add("deadline")
    return bad


def _only(policy: str, pub_qos: QoSProfile, sub_qos: QoSProfile) -> tuple[QoSProfile, QoSProfile]:
    """Copies of the pair in which every policy but ``policy`` is made equal (compatible)."""
    pub, sub = _copy(pub_qos), _copy(sub_qos)
    for other in POLICIES:
        if other != policy:
            setattr(sub, other, getattr(pub, other))
    return pub, sub


def _copy(qos: QoSProfile) -> QoSProfile:
    return QoSProfile(
        history=qos.history,
        depth=qos.depth,
        reliability=qos.reliability,
        durability=qos.durability,
        deadline=qos.deadline,
        lifespan=qos.lifespan,
        liveliness=qos.liveliness,
        liveliness_lease_duration=qos.liveliness_lease_duration,
    )


def rclpy_incompatible_policies(pub_qos: QoSProfile, sub_qos: QoSProfile) -> set[str]:
    """Which policies rclpy's own ``qos_check_compatible`` rejects, one policy at a time."""
    bad = set()
    for policy in POLICIES:
        verdict, _ = qos_check_compatible(*_only(policy, pub_qos, sub_qos))
        if verdict == QoSCompatibility.ERROR:
            bad.add(policy)
    return bad


@dataclass
class IncompatibilityReport:
    """What a publisher/subscription pair saw: the events each side raised, and data."""

    publisher_events: list[str]
    subscription_events: list[str]
    received: int
    sent: int
    connected: bool

    def summary(self) -> str:
        pub = ", ".join(self.publisher_events) or "none"
        sub = ", ".join(self.subscription_events) or "none"
        return (
            f"connected: {self.connected}; received {self.received} of {self.sent}; "
            f"incompatible-QoS events: publisher [{pub}], subscription [{sub}]"
        )


def _policy_name(info: QoSRequestedIncompatibleQoSInfo | QoSOfferedIncompatibleQoSInfo) -> str:
    return QoSPolicyKind(info.last_policy_kind).name


def watch_incompatibility(
    pub_qos: QoSProfile,
    sub_qos: QoSProfile,
    topic: str = "qos_pair",
    sent: int = 5,
    timeout: float = 3.0,
    session: Session | None = None,
) -> IncompatibilityReport:
    """Create the pair with incompatible-QoS event callbacks on both sides, publish a few
    messages, and report the events caught and how many messages arrived."""
    ros = notebook_session(session)
    ros.init()
    pub_events: list[str] = []
    sub_events: list[str] = []
    received: list[str] = []
    pub_node = Node("qos_pub")
    sub_node = Node("qos_sub")
    try:
        publisher = pub_node.create_publisher(
            String,
            topic,
            pub_qos,
            event_callbacks=PublisherEventCallbacks(
                incompatible_qos=lambda info: pub_events.append(_policy_name(info))
            ),
        )
        subscription = sub_node.create_subscription(
            String,
            topic,
            lambda msg: received.append(msg.data),
            sub_qos,
            event_callbacks=SubscriptionEventCallbacks(
                incompatible_qos=lambda info: sub_events.append(_policy_name(info))
            ),
        )
        connected = (
            ros.spin_until(
                lambda: publisher.get_subscription_count() > 0 or (pub_events and sub_events),
                pub_node,
                sub_node,
                timeout=timeout,
            )
            and publisher.get_subscription_count() > 0
        )
        for i in range(sent):
            publisher.publish(String(data=str(i)))
            ros.spin_for(0.02, pub_node, sub_node)
        ros.spin_until(lambda: len(received) >= sent, pub_node, sub_node, timeout=0.3)
        del subscription
    finally:
        ros.remove(pub_node)
        ros.remove(sub_node)
    return IncompatibilityReport(pub_events, sub_events, len(received), sent, connected)
