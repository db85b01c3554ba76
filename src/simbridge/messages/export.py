"""Turn messages into plain data: dicts, JSON text and MessagePack bytes."""

from __future__ import annotations

import base64
import json
import math
from collections.abc import Callable
from typing import Any

import msgpack
import numpy as np

from simbridge.errors import MessageError

from .schema import NUMPY_DTYPES, FieldSpec, MessageSchema, canonical_of

__all__ = ["Exporter"]

_BYTES_TYPES = ("uint8", "char")


class Exporter:
    """Converts message objects into dicts of Python primitives, JSON and MessagePack."""

    def __init__(
        self, schema_of: Callable[[str], MessageSchema], *, ros2_time: bool = False
    ) -> None:
        """`ros2_time`: spell time and duration as ROS 2 does ({sec, nanosec})."""
        self._schema_of = schema_of
        self._time_keys = ("sec", "nanosec") if ros2_time else ("secs", "nsecs")

    def to_dict(self, msg: object) -> dict[str, Any]:
        """Fields by ROS name; time as {secs, nsecs} (ROS 2: {sec, nanosec}), uint8[]/char[]
        as bytes, arrays as lists."""
        msgtype = getattr(msg, "__msgtype__", None)
        if not isinstance(msgtype, str):
            raise MessageError(f"not a message object: {type(msg).__name__}")
        schema = self._schema_of(canonical_of(msgtype))
        return {spec.name: self._field(spec, getattr(msg, spec.attr)) for spec in schema.fields}

    def to_json(self, msg: object) -> str:
        """Strict JSON text of to_dict(msg), rosbridge style: uint8[]/char[] as base64 strings,
        NaN and +-Infinity (which JSON cannot spell) as null."""
        data = self.to_dict(msg)
        try:
            return _dumps(data)
        except ValueError:  # a non-finite float somewhere: the rare, slower path
            return _dumps(_finite_or_null(data))

    def to_msgpack(self, msg: object) -> bytes:
        """MessagePack bytes of to_dict(msg) (uint8[]/char[] as bin)."""
        packed: bytes = msgpack.packb(self.to_dict(msg), use_bin_type=True)
        return packed

    def _field(self, spec: FieldSpec, value: Any) -> Any:
        if not spec.array:
            return self._scalar(spec, value)
        if spec.type in NUMPY_DTYPES:
            array = np.asarray(value, dtype=NUMPY_DTYPES[spec.type])
            return array.tobytes() if spec.type in _BYTES_TYPES else array.tolist()
        return [self._scalar(spec, item) for item in value]

    def _scalar(self, spec: FieldSpec, value: Any) -> Any:
        if spec.is_message:
            return self.to_dict(value)
        if spec.type in ("time", "duration"):
            secs, nsecs = self._time_keys
            return {secs: int(value.sec), nsecs: int(value.nanosec)}
        if isinstance(value, np.generic):
            return value.item()
        return value


def _dumps(data: object) -> str:
    return json.dumps(data, default=_json_default, separators=(",", ":"), allow_nan=False)


def _finite_or_null(value: object) -> object:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {key: _finite_or_null(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_finite_or_null(item) for item in value]
    return value


def _json_default(value: object) -> object:
    if isinstance(value, bytes):
        return base64.b64encode(value).decode("ascii")
    raise TypeError(f"cannot convert {type(value).__name__} to JSON")
