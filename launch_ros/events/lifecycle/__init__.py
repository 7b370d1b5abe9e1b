"""``launch_ros.events.lifecycle``: lifecycle transitions (see ``rosbook.launch.lifecycle``)."""

from rosbook.launch.lifecycle import ChangeState, StateTransition, matches_node_name

__all__ = ["ChangeState", "StateTransition", "matches_node_name"]
