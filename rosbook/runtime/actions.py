"""Actions in a notebook: an awaitable sleep for servers, and a bounded goal client.

An action server's execute callback runs as a coroutine on the executor; awaiting
``sleep(node, seconds)`` hands the executor back until a one-shot timer on the node's
clock fires, so feedback is paced by ROS time (simulated time in checks) and cancel
requests are served in between. ``run_goal`` plays the client's part of the protocol
(send a goal, collect feedback, cancel it if asked, wait for the result), always
bounded in time.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from action_msgs.msg import GoalStatus
from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.task import Future

from rosbook.runtime.interfaces import interface_name
from rosbook.runtime.services import ServiceTimeout, wait_for_server
from rosbook.runtime.session import spin_node_until

#: Names of ``action_msgs/msg/GoalStatus`` values.
STATUS = {
    GoalStatus.STATUS_UNKNOWN: "UNKNOWN",
    GoalStatus.STATUS_ACCEPTED: "ACCEPTED",
    GoalStatus.STATUS_EXECUTING: "EXECUTING",
    GoalStatus.STATUS_CANCELING: "CANCELING",
    GoalStatus.STATUS_SUCCEEDED: "SUCCEEDED",
    GoalStatus.STATUS_CANCELED: "CANCELED",
    GoalStatus.STATUS_ABORTED: "ABORTED",
}


async def sleep(node: Node, seconds: float) -> None:
    """Pause a coroutine for ``seconds`` of the node's clock: ``await sleep(node, s)``.

    A one-shot timer completes a future the coroutine awaits; meanwhile the executor
    runs other callbacks. The timer is destroyed by the coroutine once it resumes,
    never inside its own callback (the executor may still hold it there); or when the
    coroutine is closed unfinished (its process stopped mid-goal), maybe after its node
    destroyed it: then ``destroy_timer`` does nothing, and no error hides the close.
    """
    future = Future()

    def wake() -> None:
        if not future.done():
            future.set_result(None)

    timer = node.create_timer(seconds, wake)
    try:
        await future
    finally:
        node.destroy_timer(timer)


async def clients_listen(node: Node, action_name: str, guard: float = 10.0) -> bool:
    """Wait until this node's participant has found every goal sender's feedback subscription.

    An action server hears of a client's goal-request writer and of its feedback
    subscription separately (DDS announces writers and readers on channels of their
    own), so a goal can arrive before its sender's feedback subscription is known:
    feedback published then reaches nobody and is lost, not late. Each client has one of
    each, so once the graph counts as many feedback subscriptions as goal senders,
    every sender listens. Polls the graph on the node's clock; ``guard`` (seconds of
    that clock) only bounds the wait: ``False`` if it ran out.
    """
    name = "/" + action_name.strip("/")
    senders = f"rq{name}/_action/send_goalRequest"  # the DDS topic of goal requests
    for _ in range(max(1, round(guard / 0.01))):
        feedback = node.count_subscribers(f"{name}/_action/feedback")
        if feedback >= len(node.get_publishers_info_by_topic(senders, no_mangle=True)):
            return True
        await sleep(node, 0.01)
    return False


@dataclass
class GoalRun:
    """What a client saw of one goal: acceptance, feedback in order, final status, result."""

    accepted: bool = False
    goal_id: str | None = None  # the goal's UUID in hex, once accepted
    feedback: list[Any] = field(default_factory=list)
    feedback_times: list[float] = field(default_factory=list)
    status: int = GoalStatus.STATUS_UNKNOWN
    result: Any = None
    cancel_sent_at: int | None = None  # feedback count when the cancel request went out
    cancel_time: float | None = None  # client clock then (seconds)
    end_time: float | None = None  # client clock when the result arrived (seconds)

    @property
    def status_name(self) -> str:
        return STATUS.get(self.status, str(self.status))


def interrupted(exc: BaseException) -> bool:
    """Whether ``exc`` is Ctrl-C: a ``KeyboardInterrupt``, also one that landed while
    rclpy's C++ code turned a message into Python, where pybind11 raises a ``TypeError``
    ("Unable to convert function return value") caused by it."""
    seen: BaseException | None = exc
    while seen is not None:
        if isinstance(seen, KeyboardInterrupt):
            return True
        seen = seen.__cause__ or seen.__context__
    return False


def run_goal(
    node: Node,
    action_type: type,
    action: str,
    goal: Any,
    *,
    timeout: float = 10.0,
    discovery: float | None = None,
    cancel_after: int | None = None,
    on_feedback: Callable[[Any], None] | None = None,
    on_accepted: Callable[[str], None] | None = None,
    on_ready: Callable[[], None] | None = None,
    spin: Callable[[Callable[[], bool], float], bool] | None = None,
) -> GoalRun:
    """Send ``goal`` to ``action`` and follow it to its end (or until ``timeout``).

    ``discovery`` bounds, in wall-clock seconds, the wait for the server to be found
    (default: ``timeout``). Either limit passing raises ``ServiceTimeout``.

    ``cancel_after=n`` requests cancellation once ``n`` feedback messages arrived.
    ``on_feedback(feedback)`` and ``on_accepted(goal_id_hex)`` are called as they come;
    ``on_ready()`` once the server is found, before the goal goes out (a check in another
    process waits there until the server has discovered the client's feedback
    subscription: feedback sent before that is lost).
    Interrupted (Ctrl-C, a notebook's stop button) while the goal runs, it requests the
    goal's cancellation before the ``KeyboardInterrupt`` goes on, as ``ros2 action
    send_goal`` does (``interrupted``: also when the interrupt came out of rclpy as
    another error).
    ``spin(condition, timeout)`` moves the world on while waiting (default: spin the
    node, with the whole session when it is a session node); pass one that advances a
    simulated clock to run a server on simulated time.
    """
    spin = spin or (lambda cond, t: spin_node_until(node, cond, t))
    client = ActionClient(node, action_type, action)
    run = GoalRun()
    label = f"{node.resolve_topic_name(action)} ({interface_name(action_type)})"
    try:
        wait_for_server(client, label, timeout if discovery is None else discovery)
        if on_ready is not None:
            on_ready()

        def now() -> float:
            return node.get_clock().now().nanoseconds / 1e9

        def feedback(message: Any) -> None:
            run.feedback.append(message.feedback)
            run.feedback_times.append(now())
            if on_feedback is not None:
                on_feedback(message.feedback)

        sent = client.send_goal_async(goal, feedback_callback=feedback)
        if not spin(sent.done, timeout):
            raise ServiceTimeout(
                f"action server '{label}' did not answer the goal request within {timeout:g} s"
            )
        handle = sent.result()
        run.accepted = bool(handle.accepted)
        if not run.accepted:
            run.status = GoalStatus.STATUS_ABORTED
            return run
        run.goal_id = bytes(handle.goal_id.uuid).hex()
        if on_accepted is not None:
            on_accepted(run.goal_id)
        result = handle.get_result_async()

        def cancel() -> Future:
            run.cancel_sent_at = len(run.feedback)
            run.cancel_time = now()
            return handle.cancel_goal_async()

        try:
            if cancel_after is not None:
                spin(lambda: result.done() or len(run.feedback) >= cancel_after, timeout)
                if not result.done():
                    cancel()
            spin(result.done, timeout)
        except BaseException as exc:  # Ctrl-C, or a notebook cell interrupted: stop the goal
            if not interrupted(exc):
                raise
            if not result.done() and run.cancel_sent_at is None:
                canceling = cancel()
                spin(canceling.done, 2.0)
            if isinstance(exc, KeyboardInterrupt):
                raise
            raise KeyboardInterrupt from exc
        if result.done():
            run.end_time = now()
            run.status = result.result().status
            run.result = result.result().result
        return run
    finally:
        client.destroy()
