"""``launch_ros.substitutions`` (see ``rosbook.launch.substitutions``)."""

from rosbook.launch.substitutions import (
    ExecutableInPackage,
    FindPackage,
    FindPackagePrefix,
    FindPackageShare,
    Parameter,
)

__all__ = [
    "ExecutableInPackage",
    "FindPackage",
    "FindPackagePrefix",
    "FindPackageShare",
    "Parameter",
]
