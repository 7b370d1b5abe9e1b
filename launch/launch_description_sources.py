"""``launch.launch_description_sources``: Python launch files only (no XML or YAML here)."""

from rosbook.launch.launcher import AnyLaunchDescriptionSource, PythonLaunchDescriptionSource

__all__ = ["AnyLaunchDescriptionSource", "PythonLaunchDescriptionSource"]
