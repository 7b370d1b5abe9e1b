"""``tf2_ros.transform_listener`` (see ``rosbook.runtime.transforms``)."""

from rosbook.runtime.transforms import TransformListener

__all__ = ["TransformListener"]
