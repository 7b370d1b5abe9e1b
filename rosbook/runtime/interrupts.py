"""A Ctrl-C held back while a block runs, and acted on once it is done.

Where a Ctrl-C (SIGINT; a notebook's stop button) must not land half-way: the grader
saving and counting a row, an rclpy executor being made (rclpy 7.1.6 leaves a half-made
one, or its half-made SIGINT guard condition, whose ``__del__`` prints "Exception ignored
... AttributeError" to stderr when collected). This module imports no ROS: the grader's
main process uses it too.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def ctrl_c_held() -> Iterator[None]:
    """Hold back a SIGINT that comes during the block; act on it as the block ends (the
    handler that was in place runs then: ``KeyboardInterrupt`` by default).

    Only the main thread can hold it; elsewhere the block just runs. So does it where
    rclpy's own signal handler is installed (``rclpy.init``'s default): swapping Python's
    handler would drop rclpy's. An ignored Ctrl-C stays ignored.
    """
    previous = signal.getsignal(signal.SIGINT)
    if (
        threading.current_thread() is not threading.main_thread()
        or not callable(previous)
        or _rclpy_handles_signals()
    ):
        yield
        return
    caught: list[object] = []
    signal.signal(signal.SIGINT, lambda signum, frame: caught.append(frame))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        previous(signal.SIGINT, caught[0])


def _rclpy_handles_signals() -> bool:
    """Whether rclpy installed its signal handlers in this process (never without rclpy)."""
    signals = sys.modules.get("rclpy.signals")
    if signals is None:
        return False
    options = signals.get_current_signal_handlers_options()
    return bool(options != signals.SignalHandlerOptions.NO)
