"""``tf2_ros.static_transform_broadcaster`` (see ``rosbook.runtime.transforms``)."""

from rosbook.runtime.transforms import StaticTransformBroadcaster

__all__ = ["StaticTransformBroadcaster"]
