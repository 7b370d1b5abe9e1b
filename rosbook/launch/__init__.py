"""Workspaces and launching: colcon workspaces and packages (``workspace``), the process
launcher (``launcher``) that ``ros2 launch`` runs, its substitutions and conditions
(``substitutions``), events and handlers (``events``), XML and YAML launch files
(``frontend``), lifecycle and composable nodes (``lifecycle``, ``components``). Launch
files reach them under upstream's names, through this project's top-level ``launch``,
``launch_ros``, ``launch_xml`` and ``launch_yaml`` packages.

``from rosbook.launch import LaunchDescription, Node`` still gives the names of
``rosbook.launch.launcher``, loaded on first use.
"""

from rosbook import names_of

__getattr__ = names_of(__name__, "launcher")
