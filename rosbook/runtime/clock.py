"""The one lockstep simulated clock: ``/clock`` moved in steps, each held until followed.

Nodes with ``use_sim_time`` read their time from ``/clock``; a step of simulated time is
only over when every node that should react to it reads the new time. Three users drive
time this way, all through :class:`LockstepClock`:

- the notebook session's ``SimClock`` (``rosbook.runtime.session``): checks of rates, periods and
  timeouts, the nodes spun in the caller's thread;
- the QoS chapter's runs (``rosbook.demos.qos``): nodes spun by executors in threads of their
  own, the clock only publishes and waits;
- the simulator (``rosbook.sim.node.Simulation``): physics, sensors and controllers in
  lockstep.

How the waiting nodes make progress is the caller's: ``spin`` runs their callbacks in this
thread (lockstep in one thread), or, without it, other threads spin them and the clock
only waits. A wall-clock limit guards against a node that never follows (created before
simulated time was switched on, or blocked); hitting it is a ``TimeoutError`` naming the
nodes, never a verdict on their speed.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable

from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock

from rosbook.runtime.cdr import CdrFields

#: Wall seconds between re-publishing a step nobody has followed yet.
REPUBLISH_S = 0.05
#: Default wall-clock limit for the nodes to follow one step (a guard against hangs).
CATCH_UP_TIMEOUT_S = 30.0

NS = 1_000_000_000


def to_ns(seconds: float) -> int:
    """Seconds as whole nanoseconds (the resolution of ROS time)."""
    return int(round(seconds * 1e9))


def stamp(t_ns: int) -> tuple[int, int]:
    """``(sec, nanosec)`` of a ROS time stamp."""
    return divmod(t_ns, NS)


def now_ns(node: Node) -> int:
    """What ``node``'s clock reads now, in nanoseconds."""
    return node.get_clock().now().nanoseconds


class LockstepClock:
    """Publishes ``/clock`` from ``node`` and holds each step until the watched nodes follow."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self._pub: Publisher = node.create_publisher(
            Clock,
            "/clock",
            QoSProfile(depth=10),
            event_callbacks=PublisherEventCallbacks(use_default_callbacks=False),
        )
        self._msg = CdrFields(Clock(), ("clock.sec", "clock.nanosec"))  # sent serialized
        self.now_ns = 0

    @property
    def now(self) -> float:
        """The current simulated time in seconds."""
        return self.now_ns / 1e9

    def publish(self) -> None:
        """Publish the current time (again, for a node that missed it)."""
        self._pub.publish(self._msg.pack(*stamp(self.now_ns)))

    def subscriber_count(self) -> int:
        """How many time sources (in any process) listen to this clock."""
        return self._pub.get_subscription_count()

    def set(
        self,
        target_ns: int,
        nodes: Iterable[Node] = (),
        *,
        spin: Callable[[float], None] | None = None,
        timeout: float = CATCH_UP_TIMEOUT_S,
        hint: str = "",
    ) -> bool:
        """Move to ``target_ns`` and return once every node of ``nodes`` reads at least it.

        ``spin(seconds)`` runs the nodes' ready callbacks for at most ``seconds`` (their
        ``/clock`` subscriptions among them); without it, other threads spin the nodes.
        Raises ``TimeoutError`` (naming the nodes, then ``hint``) when they do not follow
        within ``timeout`` seconds of wall time. Returns whether it had to wait.
        """
        self.now_ns = target_ns
        self.publish()
        watched = list(nodes)
        behind = [n for n in watched if now_ns(n) < target_ns]
        if not behind:
            return False
        started = time.monotonic()
        republished = started
        while True:
            if spin is not None:
                spin(0.002)
            else:
                time.sleep(0.0002)
            behind = [n for n in behind if now_ns(n) < target_ns]
            if not behind:
                return True
            now = time.monotonic()
            if now - started > timeout:
                names = ", ".join(n.get_name() for n in behind)
                raise TimeoutError(
                    f"timeout: node(s) {names} did not follow /clock to "
                    f"t={target_ns / 1e9:.3f} s within {timeout:g} s of wall time{hint}"
                )
            if now - republished > REPUBLISH_S:
                self.publish()
                republished = now
