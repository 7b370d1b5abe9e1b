"""``launch.logging``: the loggers of a launch (``get_logger('launch.user')``)."""

from rosbook.launch.launcher import get_logger, launch_config

__all__ = ["get_logger", "launch_config"]
