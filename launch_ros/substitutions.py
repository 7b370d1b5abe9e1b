"""``launch_ros.substitutions`` (see ``rosbook.launch.substitutions``)."""

from rosbook.launch.substitutions import FindPackageShare

__all__ = ["FindPackageShare"]
