"""``tf2_ros.buffer`` (see ``rosbook.runtime.transforms``)."""

from rosbook.runtime.transforms import Buffer

__all__ = ["Buffer"]
