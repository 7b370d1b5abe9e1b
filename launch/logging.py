"""``launch.logging``: the loggers of a launch (see ``rosbook.launch.launch_logging``)."""

from rosbook.launch.launch_logging import (
    get_logger,
    get_output_loggers,
    launch_config,
    reset,
)

__all__ = ["get_logger", "get_output_loggers", "launch_config", "reset"]
