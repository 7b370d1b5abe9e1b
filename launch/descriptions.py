"""``launch.descriptions`` (see ``rosbook.launch.descriptions``)."""

from rosbook.launch.descriptions import Executable

__all__ = ["Executable"]
