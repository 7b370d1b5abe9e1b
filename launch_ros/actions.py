"""``launch_ros.actions`` (see ``rosbook.launch.launcher``)."""

from rosbook.launch.launcher import Node, PushRosNamespace, SetParameter

__all__ = ["Node", "PushRosNamespace", "SetParameter"]
