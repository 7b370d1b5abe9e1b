"""``launch_ros`` as a full ROS 2 install has it, for the part the book and the official
tutorials use (``Node``, ``PushRosNamespace``, ``SetParameter``, ``FindPackageShare``).

The implementation is ``rosbook.launch``; these modules only give its names under
upstream's.
"""

from launch_ros import actions, substitutions

__all__ = ["actions", "substitutions"]
