"""``launch.event_handlers``: actions when an event happens (see ``rosbook.launch.events``)."""

from rosbook.launch.events import (
    OnActionEventBase,
    OnExecutionComplete,
    OnIncludeLaunchDescription,
    OnProcessExit,
    OnProcessIO,
    OnProcessStart,
    OnShutdown,
    event_named,
)

__all__ = [
    "OnActionEventBase",
    "OnExecutionComplete",
    "OnIncludeLaunchDescription",
    "OnProcessExit",
    "OnProcessIO",
    "OnProcessStart",
    "OnShutdown",
    "event_named",
]
