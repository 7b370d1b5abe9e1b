"""A message's numbers written into (and read from) its serialized bytes in place.

rclpy converts a message between Python and C field by field at every publish and take:
for ``nav_msgs/msg/Odometry`` that is tens of microseconds, as much as a physics step of
the simulator. A publisher also sends serialized bytes (``publish(bytes)``), and a
subscription hands them over when taken raw; where a loop sends the same message with
a few numbers changed, ``CdrFields`` keeps its serialized form and writes those numbers
at their places: the bytes are the ones rclpy would have made.

The places are found, not computed: each field is set to a marker value in a copy of
the message, which is serialized, and the marker is looked up (alignment and string
lengths need no CDR arithmetic here; a field whose marker is not found exactly once is
refused).
"""

from __future__ import annotations

import copy
import struct
from collections.abc import Sequence
from typing import Any

from rclpy.serialization import serialize_message

#: struct formats of the numeric field types this handles, and each one's marker value.
_FORMATS = {
    "double": ("d", 1.0123456789012345e-300),
    "int32": ("i", 0x5A3C7E19),
    "uint32": ("I", 0x5A3C7E19),
}


class CdrFields:
    """``msg`` serialized, with the numeric fields at ``paths`` (dotted) writable."""

    def __init__(self, msg: Any, paths: Sequence[str]) -> None:
        serialized = serialize_message(msg)
        # byte 1 of the encapsulation header: 0 big-endian CDR, 1 little-endian
        order = "<" if serialized[1] == 1 else ">"
        self._buffer = bytearray(serialized)
        self.places: list[tuple[struct.Struct, int]] = []
        for path in paths:
            parent_path, _, name = path.rpartition(".")
            kind = _field_type(msg, path)
            if kind not in _FORMATS:
                raise TypeError(f"{path} is a {kind}; CdrFields writes {', '.join(_FORMATS)}")
            code, marker = _FORMATS[kind]
            packer = struct.Struct(order + code)
            probe = copy.deepcopy(msg)
            setattr(_get(probe, parent_path), name, marker)
            marked = serialize_message(probe)
            found = [
                i
                for i in range(len(marked) - packer.size + 1)
                if marked[i : i + packer.size] == packer.pack(marker)
            ]
            if len(found) != 1 or len(marked) != len(serialized):
                raise ValueError(f"{path}: its place in the serialized message was not found")
            self.places.append((packer, found[0]))

    def pack(self, *values: float) -> bytes:
        """The message with the fields set to ``values`` (in the order of ``paths``)."""
        buffer = self._buffer
        for (packer, offset), value in zip(self.places, values, strict=True):
            packer.pack_into(buffer, offset, value)
        return bytes(buffer)

    def unpack(self, data: bytes) -> tuple[float, ...]:
        """The fields' values in ``data``, a message of the same type taken raw."""
        return tuple(packer.unpack_from(data, offset)[0] for packer, offset in self.places)


def _get(msg: Any, path: str) -> Any:
    for name in filter(None, path.split(".")):
        msg = getattr(msg, name)
    return msg


def _field_type(msg: Any, path: str) -> str:
    parent_path, _, name = path.rpartition(".")
    parent = _get(msg, parent_path)
    return str(parent.get_fields_and_field_types()[name])
