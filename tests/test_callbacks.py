"""rosbook.runtime.callbacks: a lockstep's callbacks run without rclpy's per-callback waits,
and everything rclpy's executor would run still runs."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from rclpy.node import Node
from std_msgs.msg import Int64

from rosbook.runtime.actions import sleep
from rosbook.runtime.callbacks import Callbacks, WakingExecutor
from rosbook.runtime.session import Session


@pytest.fixture
def runner(session: Session) -> Iterator[Callbacks]:
    node = Node("runner_node")
    executor = WakingExecutor()
    executor.add_node(node)
    yield Callbacks([node], executor)
    executor.remove_node(node)
    executor.shutdown(timeout_sec=0)


def test_spin_waits_for_a_message_on_rcl_not_with_rclpys_executor(
    runner: Callbacks, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The message of another node is taken once it arrives; the wait for it is rcl's on
    the runner's kept wait set (rclpy's would build a wait set for every callback)."""
    monkeypatch.setattr(
        WakingExecutor, "spin_once", lambda *a, **k: pytest.fail("rclpy's executor waited")
    )
    (node,) = runner.nodes
    got: list[int] = []
    node.create_subscription(Int64, "runner_topic", lambda m: got.append(m.data), 10)
    sender = Node("runner_sender")
    try:
        pub = sender.create_publisher(Int64, "runner_topic", 10)
        assert runner.spin_until(lambda: pub.get_subscription_count() > 0, timeout=30)
        pub.publish(Int64(data=7))
        assert runner.spin_until(lambda: got == [7], timeout=30), got
    finally:
        sender.destroy_node()


def test_a_coroutine_awaiting_a_timer_the_passes_served_is_resumed(runner: Callbacks) -> None:
    """An action's execute callback sleeps on a one-shot timer (``await sleep(node, s)``):
    the passes call the timer, which completes the future; nothing wakes the executor
    then, so the runner resumes pending tasks at each round as rclpy's executor does at
    each wait (without that, the kernel's agent left lab 3's countdown goal unfinished)."""
    (node,) = runner.nodes
    steps: list[int] = []

    async def count() -> None:
        for step in range(3):
            await sleep(node, 0.01)
            steps.append(step)

    task = runner.executor.create_task(count)
    assert runner.spin_until(task.done, timeout=30), steps
    assert steps == [0, 1, 2]
