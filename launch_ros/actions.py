"""``launch_ros.actions`` (see ``rosbook.launch.launcher``, ``lifecycle``, ``components``)."""

from rosbook.launch.components import ComposableNodeContainer, LoadComposableNodes
from rosbook.launch.launcher import (
    Node,
    PushROSNamespace,
    PushRosNamespace,
    ROSTimer,
    RosTimer,
    SetParameter,
    SetParametersFromFile,
    SetRemap,
    SetROSLogDir,
    SetUseSimTime,
)
from rosbook.launch.lifecycle import LifecycleNode, LifecycleTransition

__all__ = [
    "ComposableNodeContainer",
    "LifecycleNode",
    "LifecycleTransition",
    "LoadComposableNodes",
    "Node",
    "PushROSNamespace",
    "PushRosNamespace",
    "ROSTimer",
    "RosTimer",
    "SetParameter",
    "SetParametersFromFile",
    "SetROSLogDir",
    "SetRemap",
    "SetUseSimTime",
]
