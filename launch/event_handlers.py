"""``launch.event_handlers``: actions when a process starts or exits."""

from rosbook.launch.launcher import OnProcessExit, OnProcessStart

__all__ = ["OnProcessExit", "OnProcessStart"]
