"""``launch`` as a full ROS 2 install has it, for the part the book and the official
tutorials use: a launch file that imports it runs here and there unchanged.

The implementation is ``rosbook.launch.launcher`` and ``rosbook.launch.substitutions``;
these modules only give their names under upstream's.
"""

from launch import (
    actions,
    conditions,
    event_handlers,
    launch_description_sources,
    substitutions,
)
from rosbook.launch.launcher import Action, LaunchDescription
from rosbook.launch.substitutions import Condition, LaunchContext, Substitution

__all__ = [
    "Action",
    "Condition",
    "LaunchContext",
    "LaunchDescription",
    "Substitution",
    "actions",
    "conditions",
    "event_handlers",
    "launch_description_sources",
    "substitutions",
]
