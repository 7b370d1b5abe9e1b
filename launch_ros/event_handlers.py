"""``launch_ros.event_handlers`` (see ``rosbook.launch.lifecycle``)."""

from rosbook.launch.lifecycle import OnStateTransition

__all__ = ["OnStateTransition"]
