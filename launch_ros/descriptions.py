"""``launch_ros.descriptions`` (see ``rosbook.launch.descriptions``)."""

from rosbook.launch.descriptions import ComposableNode, Parameter, ParameterFile, ParameterValue

__all__ = ["ComposableNode", "Parameter", "ParameterFile", "ParameterValue"]
