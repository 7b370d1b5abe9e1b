"""``launch_ros`` as a full ROS 2 install has it: ``Node``, ``LifecycleNode``,
``PushROSNamespace``, ``FindPackageShare``, parameter descriptions and lifecycle events.

The implementation is ``rosbook.launch``; these modules only give its names under
upstream's.
"""

from launch_ros import (
    actions,
    descriptions,
    event_handlers,
    events,
    parameter_descriptions,
    ros_adapters,
    substitutions,
)

__all__ = [
    "actions",
    "descriptions",
    "event_handlers",
    "events",
    "parameter_descriptions",
    "ros_adapters",
    "substitutions",
]
