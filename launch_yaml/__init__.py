"""``launch_yaml`` as a full ROS 2 install has it: YAML launch files (``*.launch.yaml``).

The implementation is ``rosbook.launch.frontend``; these modules only give its names
under upstream's.
"""

from launch_yaml import launch_description_sources
from rosbook.launch.frontend import Entity, Parser

__all__ = ["Entity", "Parser", "launch_description_sources"]
