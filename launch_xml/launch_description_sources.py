"""``launch_xml.launch_description_sources``: an XML launch file to include."""

from rosbook.launch.launcher import XMLLaunchDescriptionSource

__all__ = ["XMLLaunchDescriptionSource"]
