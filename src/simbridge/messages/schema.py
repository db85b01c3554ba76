"""Typed field layouts derived from rosbags' field definitions (one per message type)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.typesys.base import normalize_fieldname

from simbridge.errors import MessageError

__all__ = ["NUMPY_DTYPES", "ConstantSpec", "FieldSpec", "MessageSchema", "build_schema"]

_TIME_TYPES = {"builtin_interfaces/msg/Time": "time", "builtin_interfaces/msg/Duration": "duration"}
_EMPTY_MARKER = "structure_needs_at_least_one_member"

NUMPY_DTYPES: dict[str, np.dtype[Any]] = {
    name: np.dtype(dtype)
    for name, dtype in {
        "bool": np.bool_,
        "byte": np.int8,
        "char": np.uint8,
        "int8": np.int8,
        "uint8": np.uint8,
        "int16": np.int16,
        "uint16": np.uint16,
        "int32": np.int32,
        "uint32": np.uint32,
        "int64": np.int64,
        "uint64": np.uint64,
        "float32": np.float32,
        "float64": np.float64,
    }.items()
}
"""The numpy dtype rosbags uses for arrays of each primitive type."""


@dataclass(frozen=True, slots=True)
class FieldSpec:
    """One field: ROS name, Python attribute, element type and array shape."""

    name: str
    attr: str
    type: str
    """Element type: a primitive (`float64`, `string`, `time`, ...) or a canonical message name."""
    is_message: bool
    array: str
    """"" for a scalar, "fixed" for `T[n]`, "sequence" for `T[]` / `T[<=n]`."""
    length: int
    """Fixed length, or the bound of a bounded sequence (0: unbounded)."""
    string_bound: int = 0

    @property
    def element_type_text(self) -> str:
        """The element type as written in a ROS 1 `.msg` file."""
        return f"string<={self.string_bound}" if self.string_bound else self.type

    @property
    def type_text(self) -> str:
        """The full type as written in a ROS 1 `.msg` file, e.g. `float64[9]`."""
        if self.array == "fixed":
            return f"{self.element_type_text}[{self.length}]"
        if self.array == "sequence":
            bound = f"<={self.length}" if self.length else ""
            return f"{self.element_type_text}[{bound}]"
        return self.element_type_text

    @property
    def is_numeric_array(self) -> bool:
        """Whether rosbags stores this field as a numpy array."""
        return bool(self.array) and self.type in NUMPY_DTYPES


@dataclass(frozen=True, slots=True)
class ConstantSpec:
    """A constant declared in a message (`uint8 FOO=1`)."""

    name: str
    type: str
    value: bool | int | float | str


@dataclass(frozen=True, slots=True)
class MessageSchema:
    """The layout of one message type, in declaration order."""

    name: str
    fields: tuple[FieldSpec, ...]
    constants: tuple[ConstantSpec, ...]

    def field(self, name: str) -> FieldSpec:
        """The field called `name`; MessageError lists the valid ones otherwise."""
        for spec in self.fields:
            if spec.name == name:
                return spec
        valid = ", ".join(f.name for f in self.fields) or "(none)"
        msg = f"{self.name} has no field {name!r}; valid fields: {valid}"
        raise MessageError(msg)


def canonical_of(store_key: str) -> str:
    """`pkg/msg/Type` -> `pkg/Type` (time and duration keep their ROS 1 names)."""
    if store_key in _TIME_TYPES:
        return _TIME_TYPES[store_key]
    package, _, name = store_key.rpartition("/")
    return f"{package.rpartition('/')[0]}/{name}"


def _element(desc: Any) -> tuple[str, bool, int]:
    """(type, is_message, string_bound) of a BASE or NAME descriptor."""
    kind, arg = desc
    if kind == Nodetype.NAME:
        name = canonical_of(arg)
        return name, name not in ("time", "duration"), 0
    base, bound = arg
    return base, False, int(bound or 0)


def build_schema(canonical: str, fielddef: Any) -> MessageSchema:
    """Turn a rosbags `(constants, fields)` definition into a MessageSchema."""
    consts, fields = fielddef
    specs: list[FieldSpec] = []
    for name, desc in fields:
        if name == _EMPTY_MARKER:
            continue
        kind = desc[0]
        if kind in (Nodetype.BASE, Nodetype.NAME):
            typ, is_msg, bound = _element(desc)
            specs.append(FieldSpec(name, normalize_fieldname(name), typ, is_msg, "", 0, bound))
        else:
            sub, length = desc[1]
            typ, is_msg, bound = _element(sub)
            array = "fixed" if kind == Nodetype.ARRAY else "sequence"
            specs.append(
                FieldSpec(name, normalize_fieldname(name), typ, is_msg, array, int(length), bound)
            )
    constants = tuple(ConstantSpec(name, typ, value) for name, typ, value in consts)
    return MessageSchema(canonical, tuple(specs), constants)
