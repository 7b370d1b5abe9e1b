"""Composable nodes in launch files (``launch_ros.actions.ComposableNodeContainer``,
``LoadComposableNodes``; ``launch_ros.descriptions.ComposableNode``).

A composable node is a C++ class (an ``rclcpp_components`` plugin) loaded into a
container process such as ``component_container``. Neither exists as a Python wheel, so
a launch file that uses them loads and describes (``ros2 launch -s`` walks it) with
upstream's arguments, and running it stops before anything starts with one sentence.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rosbook.launch.descriptions import ComposableNode
from rosbook.launch.launcher import Action, Node
from rosbook.launch.substitutions import (
    LaunchContext,
    LaunchError,
    SomeSubstitutionsType,
    perform_substitutions,
)


def _refuse(what: str, descriptions: Sequence[ComposableNode], context: LaunchContext) -> None:
    plugins = ", ".join(perform_substitutions(context, d.node_plugin) for d in descriptions)
    raise LaunchError(
        f"{what} needs C++ components (rclcpp_components' container and the plugins "
        f"{plugins or 'none given'}), which no Python wheel provides: run each node as its "
        "own process with launch_ros.actions.Node instead"
    )


class ComposableNodeContainer(Node):
    """A container process holding composable nodes (``component_container``)."""

    def __init__(
        self,
        *,
        name: SomeSubstitutionsType,
        namespace: SomeSubstitutionsType,
        composable_node_descriptions: list[ComposableNode] | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(name=name, namespace=namespace, **kwargs)
        self.composable_node_descriptions = list(composable_node_descriptions or [])

    def execute(self, context: LaunchContext) -> None:
        name = self.node_name(context)
        _refuse(f"ComposableNodeContainer '{name}'", self.composable_node_descriptions, context)


class LoadComposableNodes(Action):
    """Load composable nodes into a running container."""

    def __init__(
        self,
        *,
        composable_node_descriptions: list[ComposableNode],
        target_container: SomeSubstitutionsType | ComposableNodeContainer,
        **kwargs: Any,
    ) -> None:
        super().__init__(**kwargs)
        self.composable_node_descriptions = list(composable_node_descriptions)
        self.target_container = target_container

    def execute(self, context: LaunchContext) -> None:
        _refuse("LoadComposableNodes", self.composable_node_descriptions, context)
