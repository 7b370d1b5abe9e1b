"""``launch_xml`` as a full ROS 2 install has it: XML launch files (``*.launch.xml``).

The implementation is ``rosbook.launch.frontend``; these modules only give its names
under upstream's.
"""

from launch_xml import launch_description_sources
from rosbook.launch.frontend import Entity, Parser

__all__ = ["Entity", "Parser", "launch_description_sources"]
