"""``launch.events`` (see ``rosbook.launch.events``)."""

from launch.events import process
from rosbook.launch.events import (
    ExecutionComplete,
    IncludeLaunchDescription,
    Shutdown,
    TimerEvent,
    matches_action,
)

__all__ = [
    "ExecutionComplete",
    "IncludeLaunchDescription",
    "Shutdown",
    "TimerEvent",
    "matches_action",
    "process",
]
