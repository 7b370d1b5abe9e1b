"""How the ``ros2`` verbs of this project report a user's mistake: one line, exit 1."""

from __future__ import annotations

import argparse
import functools
import sys
from collections.abc import Callable

Handler = Callable[[argparse.Namespace], int]


def fail(message: str) -> int:
    """Print ``message`` on stderr and return the exit code 1."""
    print(message, file=sys.stderr)
    return 1


def reports_errors(handler: Handler) -> Handler:
    """Turn a ``GraphError``/``InterfaceError`` in ``handler`` into one line on stderr."""

    @functools.wraps(handler)
    def wrapped(args: argparse.Namespace) -> int:
        from rosbook.runtime.graph import GraphError  # rclpy: not for verbs that need none
        from rosbook.runtime.interfaces import InterfaceError

        try:
            return handler(args)
        except (GraphError, InterfaceError) as error:
            return fail(str(error))

    return wrapped
