"""``launch_ros.ros_adapters``: the launch's own ROS node (see ``rosbook.launch.lifecycle``)."""

from rosbook.launch.lifecycle import RosAdapter, get_ros_adapter, get_ros_node

__all__ = ["RosAdapter", "get_ros_adapter", "get_ros_node"]
