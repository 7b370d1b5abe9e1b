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

``from rosbook import ros`` is the notebook session. The flat module names of earlier terms
(``rosbook.checks``, ``rosbook.session``, ``rosbook.sim_node``, ...) still import, with a
DeprecationWarning naming the new place; they go away after this term.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import warnings
from collections.abc import Callable
from types import ModuleType
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


#: Earlier flat module names and where they live now.
OLD_NAMES = {
    "actions": "rosbook.runtime.actions",
    "bookpages": "rosbook.book.pages",
    "checks": "rosbook.labs.lab01",
    "demo_nodes": "rosbook.demos.nodes",
    "diff_drive": "rosbook.sim.diff_drive",
    "drive_checks": "rosbook.labs.lab05",
    "executors": "rosbook.runtime.executors",
    "graph": "rosbook.runtime.graph",
    "graph_svg": "rosbook.viz.graph_svg",
    "interfaces": "rosbook.runtime.interfaces",
    "isolation": "rosbook.runtime.isolation",
    "launch_checks": "rosbook.labs.lab06",
    "params": "rosbook.runtime.params",
    "qos": "rosbook.demos.qos",
    "qos_checks": "rosbook.labs.lab02",
    "service_checks": "rosbook.labs.lab03",
    "services": "rosbook.runtime.services",
    "session": "rosbook.runtime.session",
    "sim_node": "rosbook.sim.node",
    "sim_plot": "rosbook.sim.plot",
    "sphinx_meshcat": "rosbook.book.sphinx_meshcat",
    "twin": "rosbook.viz.twin",
    "urdf": "rosbook.robots.urdf",
    "urdf_checks": "rosbook.labs.lab04",
    "workspace": "rosbook.launch.workspace",
}


class _OldNames(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports an earlier flat name as the module it became (the same module object)."""

    def find_spec(
        self, fullname: str, path: object = None, target: object = None
    ) -> importlib.machinery.ModuleSpec | None:
        prefix, _, name = fullname.partition(".")
        if prefix != "rosbook" or name not in OLD_NAMES:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> None:
        return None

    def exec_module(self, module: ModuleType) -> None:
        new = OLD_NAMES[module.__name__.partition(".")[2]]
        warnings.warn(f"{module.__name__} is now {new}", DeprecationWarning, stacklevel=2)
        # The import system returns whatever sys.modules holds once this returns.
        sys.modules[module.__name__] = importlib.import_module(new)


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


if not any(isinstance(finder, _OldNames) for finder in sys.meta_path):
    sys.meta_path.append(_OldNames())
