"""rclpy's executors, mended where the Jazzy release trips a course's users.

**An executor interrupted while it is being made says nothing.** rclpy 7.1.6's
``Executor.__init__`` sets ``_sigint_gc`` last and ``Executor.__del__`` reads it: a Ctrl-C
(or a notebook's stop button) that lands while an executor is being made leaves a
half-made object whose ``__del__`` prints "Exception ignored in ... AttributeError" to
stderr when it is collected, maybe cells later (seen in CI: ``ros2 action send_goal``
interrupted just after the goal's acceptance; nbgrader scores a test cell 0 when it
writes to stderr). The executor is not the only half-made object: the SIGINT guard
condition it makes, interrupted in its own ``__init__``, prints the same from its
``__del__`` (seen in CI too, in the same place). So the executors here are made with a
Ctrl-C held back until they are whole (``rosbook.runtime.interrupts.ctrl_c_held``), then
raised: wherever Python owns SIGINT, as in every process of this runtime (rclpy
initialised without its signal handlers). Where rclpy's handler is installed, swapping
Python's would drop rclpy's, so nothing is held; there both executors start with
``_sigint_gc = None`` as a class attribute, and a half-made executor (not its guard
condition) is collected quietly.

**A multi-threaded executor without rclpy's Jazzy busy loop (ros2/rclpy#1452).**

In rclpy 7.1.6 (the Jazzy wheels on PyPI) the multi-threaded executor hands a callback to
its thread pool and, on its next turn, finds the same task "ready but not executing yet"
and hands it over again, and again: while one task waits in the pool's queue the
spinning thread loops without waiting, fills the queue with copies and keeps the GIL
from the pool's workers. Measured here: the QoS scenarios on the simulated clock took
0.08 s to 15 s of wall time for the same 5.6 simulated seconds, with one core at 100 %.
Rolling fixed it upstream (ros2/rclpy#1469, #1547); this executor applies the same idea
to the released rclpy: a task that already waits in the pool is not queued again; the
spinning thread waits until a worker has taken a queued task (nothing new could start
before that) and then looks again.

It is built on rclpy's public extension point only: a subclass of
``rclpy.executors.Executor`` that implements ``spin_once`` and
``spin_once_until_future_complete`` with ``wait_for_ready_callbacks``, as rclpy's
documentation of ``Executor.spin_once`` asks of a custom executor (no private method of
rclpy's ``MultiThreadedExecutor`` is overridden).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

from rclpy import executors
from rclpy.context import Context
from rclpy.executors import (
    ConditionReachedException,
    Executor,
    ExternalShutdownException,
    ShutdownException,
    TimeoutException,
    TimeoutObject,
)
from rclpy.task import Future, Task

from rosbook.runtime.interrupts import ctrl_c_held

#: The longest the spinning thread waits for a worker to take a queued task (seconds).
_QUEUED_WAIT_S = 0.05


class SingleThreadedExecutor(executors.SingleThreadedExecutor):
    """rclpy's single-threaded executor, quiet when interrupted while being made."""

    _sigint_gc = None  # read by rclpy's __del__; __init__ sets it last

    def __init__(self, *, context: Context | None = None) -> None:
        with ctrl_c_held():
            super().__init__(context=context)


class MultiThreadedExecutor(Executor):
    """Same API as ``rclpy.executors.MultiThreadedExecutor``; queues each task once."""

    _sigint_gc = None  # as in SingleThreadedExecutor

    def __init__(self, num_threads: int | None = None, *, context: Context | None = None) -> None:
        with ctrl_c_held():
            super().__init__(context=context)
        if num_threads is None:
            num_threads = len(os.sched_getaffinity(0)) or 2
        self._pool = ThreadPoolExecutor(num_threads)
        self._queued: set[Task] = set()
        self._handed: list[Task] = []  # handed to the pool; their exceptions are raised here
        self._taken = threading.Condition()

    def spin_once(self, timeout_sec: float | None = None) -> None:
        self._spin_once_until(timeout_sec, lambda: False)

    def spin_once_until_future_complete(
        self, future: Future, timeout_sec: float | TimeoutObject | None = None
    ) -> None:
        future.add_done_callback(lambda _: self.wake())
        self._spin_once_until(timeout_sec, future.done)

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        done = super().shutdown(timeout_sec)
        self._pool.shutdown(wait=False)
        return done

    def _run_queued(self, task: Task) -> None:
        with self._taken:
            self._queued.discard(task)
            self._taken.notify_all()
        task()

    def _spin_once_until(
        self, timeout_sec: float | TimeoutObject | None, wait_condition: Callable[[], bool]
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
        self._pool.submit(self._run_queued, task)
        self._handed.append(task)
        for handed in self._handed[:]:
            if handed.done():
                self._handed.remove(handed)
                handed.result()  # raise any exceptions
