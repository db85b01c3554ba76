"""Name the field a wire format cannot carry, for the error of a failed encode.

rosbags' generated serializers fail with bare `struct.error`s ("argument out of range")
that name neither field nor value. Only after such a failure, `find_unencodable` walks
the message against its definition and describes the first offending field: its path,
its value and what the format accepts. The hot path never pays for this.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.typesys.base import normalize_fieldname

from .rostime import field_layouts
from .schema import NUMPY_DTYPES, canonical_of

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = ["find_unencodable"]

_INT_RANGES = {
    name: (int(np.iinfo(dtype).min), int(np.iinfo(dtype).max))
    for name, dtype in NUMPY_DTYPES.items()
    if dtype.kind in "iu"
}
_FLOAT32_MAX = float(np.finfo(np.float32).max)
_FORMAT_NAMES = {"ros1": "ROS 1", "cdr": "CDR"}


def find_unencodable(store: Typestore, key: str, msg: object, fmt: str, path: str) -> str | None:
    """`path.to.field: what is wrong` for the first field of `msg` (store type `key`)
    that wire format `fmt` cannot carry, or None when every field looks encodable."""
    return _Walker(store, fmt).message(key, msg, path)


class _Walker:
    def __init__(self, store: Typestore, fmt: str) -> None:
        self._store = store
        self._fmt = fmt

    def message(self, key: str, msg: object, path: str) -> str | None:
        layouts = field_layouts(self._fmt, key)
        if layouts is not None:
            return self._time(key, layouts, msg, path)
        got = getattr(msg, "__msgtype__", None)
        if got != key:
            shown = canonical_of(got) if isinstance(got, str) else repr(msg)
            return f"{path}: expected a {canonical_of(key)} message, got {shown}"
        for name, desc in self._store.fielddefs[key][1]:
            if name == "structure_needs_at_least_one_member":
                continue
            value = getattr(msg, normalize_fieldname(name))
            problem = self._field(desc, value, f"{path}.{name}")
            if problem is not None:
                return problem
        return None

    def _time(
        self, key: str, layouts: tuple[tuple[str, str], ...], value: object, path: str
    ) -> str | None:
        kind = "time" if key.endswith("/Time") else "duration"
        for attr, (name, typ) in zip(("sec", "nanosec"), layouts, strict=True):
            if not hasattr(value, attr):
                return f"{path}: expected a {kind}, got {value!r}"
            where = f"{self._fmt_name} {kind} {name} ({typ})"
            problem = _integer(typ, getattr(value, attr), f"{path}.{name}", where)
            if problem is not None:
                return problem
        return None

    @property
    def _fmt_name(self) -> str:
        return _FORMAT_NAMES.get(self._fmt, self._fmt)

    def _field(self, desc: Any, value: object, path: str) -> str | None:
        kind, arg = desc
        if kind == Nodetype.NAME:
            return self.message(arg, value, path)
        if kind == Nodetype.BASE:
            return _primitive(arg[0], value, path)
        sub, length = arg
        if sub[0] == Nodetype.BASE and sub[1][0] != "string":
            return _numeric_array(sub[1][0], kind, length, value, path)
        if not isinstance(value, list | tuple):
            return f"{path}: expected a list, got {type(value).__name__}"
        if kind == Nodetype.ARRAY and len(value) != length:
            return f"{path}: needs exactly {length} elements, got {len(value)}"
        for index, item in enumerate(value):
            problem = self._field(sub, item, f"{path}[{index}]")
            if problem is not None:
                return problem
        return None


def _primitive(typ: str, value: object, path: str) -> str | None:
    if typ == "string":
        return None if isinstance(value, str) else f"{path}: expected a string, got {value!r}"
    if typ in _INT_RANGES:
        return _integer(typ, value, path, typ)
    if typ in ("float32", "float64"):
        if not isinstance(value, int | float | np.integer | np.floating):
            return f"{path}: expected a number ({typ}), got {value!r}"
        number = float(value)
        if typ == "float32" and math.isfinite(number) and abs(number) > _FLOAT32_MAX:
            return f"{path}: {value} is out of range for float32 (|x| <= {_FLOAT32_MAX:g})"
    return None


def _integer(typ: str, value: object, path: str, what: str) -> str | None:
    if not isinstance(value, int | np.integer):
        return f"{path}: expected an integer ({what}), got {value!r}"
    low, high = _INT_RANGES[typ]
    if not low <= int(value) <= high:
        return f"{path}: {int(value)} is out of range for {what} [{low}, {high}]"
    return None


def _numeric_array(typ: str, kind: int, length: int, value: object, path: str) -> str | None:
    if not isinstance(value, np.ndarray):
        return (
            f"{path}: expected a numpy array of {typ}, got {type(value).__name__} "
            "(MessageRegistry.new/from_dict convert lists)"
        )
    if value.dtype != NUMPY_DTYPES[typ]:
        return f"{path}: expected a numpy array of {typ}, got dtype {value.dtype}"
    if kind == Nodetype.ARRAY and len(value) != length:
        return f"{path}: needs exactly {length} elements, got {len(value)}"
    return None
