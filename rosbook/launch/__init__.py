"""Workspaces and launching: colcon workspaces and packages (``workspace``), the process
launcher (``launcher``) that ``ros2 launch`` runs, and its substitutions and conditions
(``substitutions``). Launch files reach the launcher under upstream's names, through this
project's top-level ``launch`` and ``launch_ros`` packages.

``from rosbook.launch import LaunchDescription, Node`` still gives the names of
``rosbook.launch.launcher``, loaded on first use.
"""

from rosbook import names_of

__getattr__ = names_of(__name__, "launcher")
