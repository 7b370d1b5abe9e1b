"""``launch.logging``: the launch's loggers and their settings, under upstream's names.

This launcher prints its own lines and each process's output itself and writes no log
files, so the settings here are what a launch file may set or read (``level``,
``log_dir``) without a log file behind them.
"""

from __future__ import annotations

import logging
import os
from typing import Any

from rosbook.launch.substitutions import LaunchContext, LaunchLogDir


def get_logger(name: str | None = None) -> logging.Logger:
    """A logger of the launch (``launch.user`` for messages of a launch file's own)."""
    return logging.getLogger(name or "launch")


class LaunchConfig:
    """The launch's logging settings (``launch.logging.launch_config``)."""

    def __init__(self) -> None:
        self._log_dir: str | None = None

    @property
    def level(self) -> int:
        return get_logger().getEffectiveLevel()

    @level.setter
    def level(self, new_level: int | str) -> None:
        get_logger().setLevel(new_level)

    @property
    def log_dir(self) -> str:
        """Where upstream would write its logs (``ROS_LOG_DIR``, else ``~/.ros/log``)."""
        if self._log_dir is not None:
            return self._log_dir
        return LaunchLogDir().perform(LaunchContext(dict(os.environ)))

    @log_dir.setter
    def log_dir(self, new_log_dir: str) -> None:
        self._log_dir = new_log_dir

    def set_screen_format(self, screen_format: str, *, screen_style: Any = None) -> None:
        """Accepted; the screen format here is upstream's default, ``[name] line``."""

    def set_log_format(self, log_format: str, *, log_style: Any = None) -> None:
        """Accepted; no log file is written."""

    def reset(self) -> None:
        self._log_dir = None
        get_logger().setLevel(logging.NOTSET)


launch_config = LaunchConfig()


def get_output_loggers(process_name: str, output_config: Any) -> tuple[logging.Logger, ...]:
    """The loggers of a process's stdout and stderr."""
    logger = get_logger(process_name)
    return logger, logger


def reset() -> None:
    """Back to the default settings."""
    launch_config.reset()
