"""``launch.frontend``: XML and YAML launch files (see ``rosbook.launch.frontend``)."""

from rosbook.launch.frontend import Entity, Parser

__all__ = ["Entity", "Parser"]
