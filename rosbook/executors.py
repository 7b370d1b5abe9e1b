"""rclpy's MultiThreadedExecutor without its Jazzy busy loop (ros2/rclpy#1452).

In rclpy 7.1.6 (the Jazzy wheels on PyPI) the multi-threaded executor hands a callback to
its thread pool and, on its next turn, finds the same task "ready but not executing yet"
and hands it over again, and again: while one task waits in the pool's queue the
spinning thread loops without waiting, fills the queue with copies and keeps the GIL
from the pool's workers. Measured here: the QoS scenarios on the simulated clock took
0.08 s to 15 s of wall time for the same 5.6 simulated seconds, with one core at 100 %.
Rolling fixed it upstream (ros2/rclpy#1469, #1547); this subclass applies the same idea
to the released rclpy: a task that already waits in the pool is not queued again; the
spinning thread waits until a worker has taken a queued task (nothing new could start
before that) and then looks again.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from rclpy.executors import (
    ConditionReachedException,
    ExternalShutdownException,
    ShutdownException,
    TimeoutException,
    TimeoutObject,
)
from rclpy.executors import MultiThreadedExecutor as _RclpyMultiThreadedExecutor
from rclpy.task import Task

#: The longest the spinning thread waits for a worker to take a queued task (seconds).
_QUEUED_WAIT_S = 0.05


class MultiThreadedExecutor(_RclpyMultiThreadedExecutor):
    """Same API as ``rclpy.executors.MultiThreadedExecutor``; queues each task once."""

    def __init__(self, num_threads: int | None = None, **kwargs: object) -> None:
        super().__init__(num_threads, **kwargs)  # type: ignore[arg-type]
        self._queued: set[Task] = set()
        self._taken = threading.Condition()

    def _run_queued(self, task: Task) -> None:
        with self._taken:
            self._queued.discard(task)
            self._taken.notify_all()
        task()

    def _spin_once_impl(
        self,
        timeout_sec: float | TimeoutObject | None = None,
        wait_condition: Callable[[], bool] = lambda: False,
    ) -> None:
        try:
            task, _entity, _node = self.wait_for_ready_callbacks(timeout_sec, None, wait_condition)
        except (
            ExternalShutdownException,
            ShutdownException,
            TimeoutException,
            ConditionReachedException,
        ):
            return
        with self._taken:
            if task in self._queued:
                limit = getattr(timeout_sec, "timeout", timeout_sec)  # float or TimeoutObject
                wait = _QUEUED_WAIT_S if limit is None or limit < 0 else min(limit, _QUEUED_WAIT_S)
                self._taken.wait_for(lambda: task not in self._queued or wait_condition(), wait)
                return
            self._queued.add(task)
        self._executor.submit(self._run_queued, task)
        self._futures.append(task)
        for future in self._futures[:]:
            if future.done():
                self._futures.remove(future)
                future.result()  # raise any exceptions
