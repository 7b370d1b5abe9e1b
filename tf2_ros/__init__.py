"""``tf2_ros`` as a full ROS 2 install has it: a node that imports it runs here and there
unchanged (no tf2 wheel exists).

The implementation is ``rosbook.runtime.transforms``; these modules only give its names
under upstream's (``tf2_ros.buffer``, ``tf2_ros.transform_listener``, ...).
"""

from rosbook.runtime.transforms import (
    Buffer,
    BufferCore,
    ConnectivityException,
    ExtrapolationException,
    InvalidArgumentException,
    LookupException,
    StaticTransformBroadcaster,
    TimeoutException,
    TransformBroadcaster,
    TransformException,
    TransformListener,
)
from tf2_ros import (
    buffer,
    static_transform_broadcaster,
    transform_broadcaster,
    transform_listener,
)

__all__ = [
    "Buffer",
    "BufferCore",
    "ConnectivityException",
    "ExtrapolationException",
    "InvalidArgumentException",
    "LookupException",
    "StaticTransformBroadcaster",
    "TimeoutException",
    "TransformBroadcaster",
    "TransformException",
    "TransformListener",
    "buffer",
    "static_transform_broadcaster",
    "transform_broadcaster",
    "transform_listener",
]
