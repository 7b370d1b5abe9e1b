"""``launch_ros.parameter_descriptions`` (see ``rosbook.launch.descriptions``)."""

from rosbook.launch.descriptions import Parameter, ParameterFile, ParameterValue

__all__ = ["Parameter", "ParameterFile", "ParameterValue"]
