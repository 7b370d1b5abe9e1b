"""``tf2_ros.transform_broadcaster`` (see ``rosbook.runtime.transforms``)."""

from rosbook.runtime.transforms import TransformBroadcaster

__all__ = ["TransformBroadcaster"]
