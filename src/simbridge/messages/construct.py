"""Build messages: zero-initialised defaults and conversion from plain Python data."""

from __future__ import annotations

import base64
import binascii
import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from simbridge.errors import MessageError

from .schema import NUMPY_DTYPES, FieldSpec, MessageSchema

__all__ = ["Builder", "TypeSource"]

_INT_RANGES: dict[str, tuple[int, int]] = {
    name: (int(np.iinfo(dtype).min), int(np.iinfo(dtype).max))
    for name, dtype in NUMPY_DTYPES.items()
    if dtype.kind in "iu"
}
_FLOATS = ("float32", "float64")
_BYTE_LIKE = ("uint8", "char", "int8", "byte")


class TypeSource(Protocol):
    """What the builder needs from a registry: layouts and classes by canonical name."""

    def schema(self, name: str) -> MessageSchema:
        """The layout of message type `name`."""
        ...

    def msg_class(self, name: str) -> type[Any]:
        """The rosbags dataclass of message type `name` (also `time` and `duration`)."""
        ...


Maker = Callable[[], Any]


class Builder:
    """Creates message objects; per-type default factories are compiled once and cached."""

    def __init__(self, source: TypeSource, time_ranges: Mapping[str, tuple[int, int]]) -> None:
        """`time_ranges`: the seconds `time` and `duration` may hold (ROS 1: uint32 time)."""
        self._source = source
        self._time_ranges = dict(time_ranges)
        self._factories: dict[str, Maker] = {}
        self._fields: dict[str, dict[str, FieldSpec]] = {}

    def default(self, name: str) -> Any:
        """A new message of type `name` with every field zero, empty or default-constructed."""
        return self.factory(name)()

    def factory(self, name: str) -> Maker:
        """A zero-argument callable returning fresh default messages of type `name`."""
        maker = self._factories.get(name)
        if maker is None:
            maker = self._factories[name] = self._make_factory(name)
        return maker

    def from_dict(self, name: str, data: object, path: str | None = None) -> Any:
        """Build `name` from a mapping (missing fields default), a positional list, or a message.

        Raises MessageError naming the offending field path and, for unknown keys,
        the valid field names.
        """
        where = path or name
        cls = self._source.msg_class(name)
        if isinstance(data, cls):
            return data
        fields = self._field_map(name)
        schema = self._source.schema(name)
        if isinstance(data, Sequence) and not isinstance(data, str | bytes | bytearray):
            if len(data) != len(schema.fields):
                msg = (
                    f"{where}: a positional {name} needs {len(schema.fields)} values "
                    f"({', '.join(f.name for f in schema.fields)}), got {len(data)}"
                )
                raise MessageError(msg)
            data = {spec.name: value for spec, value in zip(schema.fields, data, strict=True)}
        if not isinstance(data, Mapping):
            msg = f"{where}: expected a mapping of {name} fields, got {type(data).__name__}"
            raise MessageError(msg)
        msg_obj = self.default(name)
        for key, value in data.items():
            spec = fields.get(key) if isinstance(key, str) else None
            if spec is None:
                valid = ", ".join(f.name for f in schema.fields) or "(none)"
                msg = f"{where}: {name} has no field {key!r}; valid fields: {valid}"
                raise MessageError(msg)
            setattr(msg_obj, spec.attr, self._convert(spec, value, f"{where}.{spec.name}"))
        return msg_obj

    # -- defaults ---------------------------------------------------------------------------

    def _make_factory(self, name: str) -> Maker:
        cls = self._source.msg_class(name)
        makers = [
            (spec.attr, self._field_default(spec)) for spec in self._source.schema(name).fields
        ]
        if not makers:
            return cls

        def make() -> Any:
            return cls(**{attr: maker() for attr, maker in makers})

        return make

    def _field_default(self, spec: FieldSpec) -> Maker:
        if spec.array and spec.type in NUMPY_DTYPES:
            dtype = NUMPY_DTYPES[spec.type]
            count = spec.length if spec.array == "fixed" else 0
            return lambda: np.zeros(count, dtype)
        element = self._scalar_default(spec.type, spec.is_message)
        if spec.array == "fixed":
            count = spec.length
            return lambda: [element() for _ in range(count)]
        if spec.array == "sequence":
            return list
        return element

    def _scalar_default(self, typ: str, is_message: bool) -> Maker:
        if is_message:
            return self.factory(typ)
        if typ in ("time", "duration"):
            cls = self._source.msg_class(typ)
            return lambda: cls(sec=0, nanosec=0)
        if typ == "string":
            return str
        if typ == "bool":
            return bool
        if typ in _FLOATS:
            return float
        return int

    def _field_map(self, name: str) -> dict[str, FieldSpec]:
        fields = self._fields.get(name)
        if fields is None:
            specs = self._source.schema(name).fields
            fields = {spec.attr: spec for spec in specs} | {spec.name: spec for spec in specs}
            self._fields[name] = fields
        return fields

    # -- conversion -------------------------------------------------------------------------

    def _convert(self, spec: FieldSpec, value: object, path: str) -> Any:
        if not spec.array:
            return self._scalar(spec.type, spec.is_message, value, path)
        if spec.type in NUMPY_DTYPES:
            array = _numeric_array(spec.type, value, path)
            _check_length(spec, len(array), path)
            return array
        if isinstance(value, str | bytes | bytearray | Mapping) or not isinstance(value, Sequence):
            msg = f"{path}: expected a list of {spec.element_type_text}, got {type(value).__name__}"
            raise MessageError(msg)
        _check_length(spec, len(value), path)
        return [
            self._scalar(spec.type, spec.is_message, item, f"{path}[{index}]")
            for index, item in enumerate(value)
        ]

    def _scalar(self, typ: str, is_message: bool, value: object, path: str) -> Any:
        if is_message:
            return self.from_dict(typ, value, path)
        if typ in ("time", "duration"):
            return self._time(typ, value, path)
        return _primitive(typ, value, path)

    def _time(self, typ: str, value: object, path: str) -> Any:
        cls = self._source.msg_class(typ)
        if isinstance(value, cls):
            return value
        if isinstance(value, str) and value == "now" and typ == "time":
            value = time.time()
        if (
            isinstance(value, Sequence)
            and not isinstance(value, str | bytes | bytearray)
            and len(value) == 2
        ):
            value = dict(zip(("secs", "nsecs"), value, strict=True))  # positional, as rostopic
        if isinstance(value, Mapping):
            keys = set(value)
            if keys <= {"secs", "nsecs"}:
                secs, nsecs = value.get("secs", 0), value.get("nsecs", 0)
            elif keys <= {"sec", "nanosec"}:
                secs, nsecs = value.get("sec", 0), value.get("nanosec", 0)
            else:
                msg = (
                    f"{path}: a {typ} has keys secs and nsecs (or sec and nanosec), "
                    f"got {sorted(keys)}"
                )
                raise MessageError(msg)
            secs = _primitive("int64", secs, f"{path}.secs")
            nsecs = _primitive("int64", nsecs, f"{path}.nsecs")
        elif (
            isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
        ):
            secs = math.floor(value)
            nsecs = round((value - secs) * 1e9)
        else:
            shapes = "{secs, nsecs}, [secs, nsecs] or seconds"
            msg = f"{path}: expected a {typ} ({shapes}), got {value!r}"
            raise MessageError(msg)
        secs, nsecs = secs + nsecs // 1_000_000_000, nsecs % 1_000_000_000
        low, high = self._time_ranges[typ]
        if not low <= secs <= high:
            msg = f"{path}: {typ} seconds {secs} out of range [{low}, {high}]"
            raise MessageError(msg)
        return cls(sec=secs, nanosec=nsecs)


def _check_length(spec: FieldSpec, length: int, path: str) -> None:
    if spec.array == "fixed" and length != spec.length:
        msg = f"{path}: {spec.type_text} needs exactly {spec.length} elements, got {length}"
        raise MessageError(msg)
    if spec.array == "sequence" and spec.length and length > spec.length:
        msg = f"{path}: {spec.type_text} holds at most {spec.length} elements, got {length}"
        raise MessageError(msg)


def _primitive(typ: str, value: object, path: str) -> Any:
    if isinstance(value, np.generic):
        value = value.item()
    if typ == "string":
        if isinstance(value, str):
            return value
        msg = f"{path}: expected a string, got {value!r}"
        raise MessageError(msg)
    if typ == "bool":
        if isinstance(value, bool) or (isinstance(value, int | float) and value in (0, 1)):
            return bool(value)
        msg = f"{path}: expected a bool, got {value!r}"
        raise MessageError(msg)
    if typ in _FLOATS:
        if isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
        if value is None:  # JSON has no NaN/Infinity: to_json writes them as null
            return math.nan
        msg = f"{path}: expected a number ({typ}), got {value!r}"
        raise MessageError(msg)
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if not isinstance(value, int) or isinstance(value, bool):
        msg = f"{path}: expected an integer ({typ}), got {value!r}"
        raise MessageError(msg)
    low, high = _INT_RANGES[typ]
    if not low <= value <= high:
        msg = f"{path}: {value} is out of range for {typ} [{low}, {high}]"
        raise MessageError(msg)
    return value


def _numeric_array(typ: str, value: object, path: str) -> np.ndarray[Any, Any]:
    dtype = NUMPY_DTYPES[typ]
    if typ in _BYTE_LIKE:
        if isinstance(value, str):
            try:
                value = base64.b64decode(value, validate=True)
            except (binascii.Error, ValueError) as exc:
                msg = f"{path}: a string for {typ}[] must be base64: {exc}"
                raise MessageError(msg) from exc
        if isinstance(value, bytes | bytearray | memoryview):
            return np.frombuffer(bytes(value), dtype=dtype).copy()
    if isinstance(value, str | bytes | bytearray | Mapping):
        msg = f"{path}: expected a list of {typ}, got {type(value).__name__}"
        raise MessageError(msg)
    if typ in _FLOATS and isinstance(value, list | tuple) and None in value:
        value = [math.nan if item is None else item for item in value]  # null from JSON
    try:
        raw = np.asarray(value)
    except (ValueError, TypeError) as exc:
        msg = f"{path}: expected a list of {typ}: {exc}"
        raise MessageError(msg) from exc
    if raw.ndim != 1 and raw.size:
        msg = f"{path}: expected a flat list of {typ}, got shape {raw.shape}"
        raise MessageError(msg)
    raw = raw.reshape(-1)
    if raw.dtype.kind not in "biuf":
        msg = f"{path}: expected numbers for {typ}[], got {raw.dtype} values"
        raise MessageError(msg)
    if dtype.kind in "iu" and raw.size:
        if raw.dtype.kind == "f" and not np.all(np.isfinite(raw) & (raw == np.round(raw))):
            msg = f"{path}: {typ}[] needs integers, got non-integral values"
            raise MessageError(msg)
        low, high = _INT_RANGES[typ]
        if raw.min() < low or raw.max() > high:
            msg = f"{path}: values out of range for {typ} [{low}, {high}]"
            raise MessageError(msg)
    elif dtype.kind == "b" and raw.size and not np.all((raw == 0) | (raw == 1)):
        msg = f"{path}: bool[] needs 0/1 or true/false values"
        raise MessageError(msg)
    return raw.astype(dtype)
