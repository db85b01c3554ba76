"""`time` and `duration`: ROS 1's wire layout and the value ranges of each ROS generation.

rosbags models both as `builtin_interfaces` Time/Duration (`int32 sec`, `uint32 nanosec`),
which is ROS 2's layout and stays the CDR one. ROS 1 (genpy, roscpp, Unity's ROS 1 mode)
defines `time` as `uint32 secs, uint32 nsecs` and `duration` as `int32 secs, int32 nsecs`,
so stamps past 2038 (secs >= 2^31) are valid ROS 1 times. `use_ros1_layout` makes a
typestore's ROS 1 (de)serializers of the two types follow ROS 1; its CDR ones are untouched.
"""

from __future__ import annotations

import dataclasses
import struct
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = [
    "DURATION_KEY",
    "ROS1_TIME_RANGES",
    "ROS2_TIME_RANGES",
    "TIME_KEY",
    "field_layouts",
    "use_ros1_layout",
]

TIME_KEY = "builtin_interfaces/msg/Time"
DURATION_KEY = "builtin_interfaces/msg/Duration"

_INT32 = (-(2**31), 2**31 - 1)
_UINT32 = (0, 2**32 - 1)

ROS1_TIME_RANGES: dict[str, tuple[int, int]] = {"time": _UINT32, "duration": _INT32}
"""Seconds a ROS 1 `time` / `duration` can carry (nanoseconds are normalised to [0, 1e9))."""

ROS2_TIME_RANGES: dict[str, tuple[int, int]] = {"time": _INT32, "duration": _INT32}
"""Seconds a ROS 2 builtin_interfaces Time / Duration can carry (`int32 sec`)."""

_ROS1_LAYOUTS = {TIME_KEY: struct.Struct("<II"), DURATION_KEY: struct.Struct("<ii")}

# (field name, primitive type) of (seconds, nanoseconds) per wire format and kind.
_FIELDS: dict[tuple[str, str], tuple[tuple[str, str], tuple[str, str]]] = {
    ("ros1", TIME_KEY): (("secs", "uint32"), ("nsecs", "uint32")),
    ("ros1", DURATION_KEY): (("secs", "int32"), ("nsecs", "int32")),
    ("cdr", TIME_KEY): (("sec", "int32"), ("nanosec", "uint32")),
    ("cdr", DURATION_KEY): (("sec", "int32"), ("nanosec", "uint32")),
}


def field_layouts(fmt: str, key: str) -> tuple[tuple[str, str], tuple[str, str]] | None:
    """((name, type) of seconds, (name, type) of nanoseconds) of a time or duration store
    key in wire format `fmt` ("ros1" or "cdr"); None for any other type."""
    return _FIELDS.get((fmt, key))


def use_ros1_layout(store: Typestore) -> None:
    """Replace the ROS 1 (de)serializers of Time and Duration in `store`'s msgdef cache.

    Generated code of every other type looks nested types up through that cache at call
    time, so headers and stamps inside any message follow ROS 1 from then on.
    """
    for key, layout in _ROS1_LAYOUTS.items():
        msgdef = store.get_msgdef(key)
        store.cache[key] = dataclasses.replace(
            msgdef, serialize_ros1=_serializer(layout), deserialize_ros1=_deserializer(layout)
        )


def _serializer(layout: struct.Struct) -> Any:
    pack_into, size = layout.pack_into, layout.size

    def serialize_ros1(rawdata: Any, pos: int, message: Any, typestore: Any) -> int:
        pack_into(rawdata, pos, message.sec, message.nanosec)
        return pos + size

    return serialize_ros1


def _deserializer(layout: struct.Struct) -> Any:
    unpack_from, size = layout.unpack_from, layout.size

    def deserialize_ros1(rawdata: Any, pos: int, cls: Any, typestore: Any) -> tuple[Any, int]:
        sec, nanosec = unpack_from(rawdata, pos)
        return cls(sec, nanosec), pos + size

    return deserialize_ros1
