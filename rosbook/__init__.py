"""rosbook: the support library shared by the course book, its labs and its grader.

The package is layered; each layer imports only the layers below it (import-linter checks
this, see ``[tool.importlinter]`` in pyproject.toml and CONTRIBUTING.md):

- ``rosbook.labs`` (each lab's checks), ``rosbook.book`` (book-build tooling)
- ``rosbook.demos`` (the chapters' experiments and demo nodes), ``rosbook.cli`` (``ros2``)
- ``rosbook.viz`` (MeshCat scenes, the digital twin, graph pictures)
- ``rosbook.sim`` (kinematics, physics, the simulator node), ``rosbook.launch`` (workspaces,
  the launcher)
- ``rosbook.runtime`` (the ROS runtime: session, executors, isolation, graph, interfaces,
  services, actions, parameters), ``rosbook.robots`` (URDF robots and their parser)

``from rosbook import ros`` is the notebook session.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

from rosbook.runtime import wheels

wheels.preload()  # before rclpy loads: the ROS wheels' libraries outside a venv too

__all__ = ["Session", "SimClock", "ros"]


def __getattr__(name: str) -> Any:
    """``rosbook.ros`` and the session's classes, imported on first use: a command that
    does not talk to ROS itself (a ``ros2`` verb the daemon answers) never loads rclpy."""
    if name in __all__:
        return getattr(importlib.import_module("rosbook.runtime.session"), name)
    raise AttributeError(f"module 'rosbook' has no attribute {name!r}")


def names_of(package: str, module: str) -> Callable[[str], Any]:
    """A package's ``__getattr__`` that gives the names of its module ``module``, loaded on
    first use: ``rosbook.sim``, ``rosbook.viz`` and ``rosbook.launch`` were single modules."""

    def __getattr__(name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        try:
            return getattr(importlib.import_module(f"{package}.{module}"), name)
        except AttributeError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None

    return __getattr__
