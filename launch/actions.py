"""``launch.actions``: the actions of launch files (see ``rosbook.launch.launcher``)."""

from rosbook.launch.launcher import (
    DeclareLaunchArgument,
    ExecuteProcess,
    GroupAction,
    IncludeLaunchDescription,
    LogInfo,
    RegisterEventHandler,
    SetLaunchConfiguration,
    Shutdown,
    TimerAction,
)

__all__ = [
    "DeclareLaunchArgument",
    "ExecuteProcess",
    "GroupAction",
    "IncludeLaunchDescription",
    "LogInfo",
    "RegisterEventHandler",
    "SetLaunchConfiguration",
    "Shutdown",
    "TimerAction",
]
