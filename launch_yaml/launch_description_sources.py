"""``launch_yaml.launch_description_sources``: a YAML launch file to include."""

from rosbook.launch.launcher import YAMLLaunchDescriptionSource

__all__ = ["YAMLLaunchDescriptionSource"]
