"""Workspaces and launching: colcon workspaces and packages (``workspace``) and the
process launcher (``launcher``) that ``ros2 launch`` runs.

``from rosbook.launch import LaunchDescription, Node`` (what launch files write) still
gives the names of ``rosbook.launch.launcher``, loaded on first use.
"""

from rosbook import names_of

__getattr__ = names_of(__name__, "launcher")
