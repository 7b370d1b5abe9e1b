"""``launch_ros.events`` (see ``rosbook.launch.lifecycle``)."""

from launch_ros.events import lifecycle
from rosbook.launch.lifecycle import matches_node_name

__all__ = ["lifecycle", "matches_node_name"]
