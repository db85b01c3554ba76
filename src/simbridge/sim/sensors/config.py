"""Sensor options as frozen dataclasses, built from scene-file dictionaries with checks."""

from __future__ import annotations

import types
import typing
from collections.abc import Mapping
from dataclasses import MISSING, dataclass, fields
from typing import Any, Self

from simbridge.errors import SimError, did_you_mean
from simbridge.sim.sensors.frames import Mount

__all__ = ["OptionError", "SensorConfig"]

Vec3 = tuple[float, float, float]


class OptionError(SimError):
    """A bad option in a sensor's configuration: `key` is the option at fault (None: the
    entry as a whole), `detail` what is wrong, so a scene file can add where it stands."""

    def __init__(self, owner: str, key: str | None, detail: str) -> None:
        super().__init__(f"{owner}: {detail}")
        self.key = key
        self.detail = detail


def _describe(hint: Any) -> str:
    """A field's type as a scene file's author reads it."""
    origin = typing.get_origin(hint)
    if origin in (types.UnionType, typing.Union):
        inner = [_describe(option) for option in typing.get_args(hint) if option is not type(None)]
        return " or ".join([*inner, "null"])
    if origin is tuple:
        args = typing.get_args(hint)
        if len(args) == 2 and args[1] is Ellipsis:
            return f"a list of {_describe(args[0]).removeprefix('a ').removeprefix('an ')}s"
        return f"a list of {len(args)} {_describe(args[0]).removeprefix('a ')}s"
    names = {bool: "true or false", int: "an integer", float: "a number", str: "a string"}
    return names.get(hint, str(hint))


def _coerce(owner: str, key: str, hint: Any, value: Any) -> Any:
    """Convert a YAML value to the field's declared type, or raise naming the key."""
    origin = typing.get_origin(hint)
    if origin in (types.UnionType, typing.Union):
        options = typing.get_args(hint)
        if value is None and type(None) in options:
            return None
        (inner,) = [option for option in options if option is not type(None)]
        return _coerce(owner, key, inner, value)
    try:
        if origin is tuple:
            args = typing.get_args(hint)
            if isinstance(value, str | bytes):
                raise TypeError(value)
            items = list(value)
            if len(args) == 2 and args[1] is Ellipsis:
                return tuple(_coerce(owner, key, args[0], item) for item in items)
            if len(items) != len(args):
                raise OptionError(
                    owner, key, f"{key}: needs {len(args)} values, got {len(items)}: {value!r}"
                )
            return tuple(
                _coerce(owner, key, arg, item) for arg, item in zip(args, items, strict=True)
            )
        if hint is bool:
            if not isinstance(value, bool):
                raise TypeError(value)
            return value
        if hint in (int, float):
            if isinstance(value, bool):
                raise TypeError(value)
            converted = hint(value)
            if hint is int and converted != value:
                raise ValueError(value)
            return converted
        if hint is str:
            if not isinstance(value, str):
                raise TypeError(value)
            return value
    except (TypeError, ValueError) as exc:
        raise OptionError(owner, key, f"{key}: must be {_describe(hint)}, got {value!r}") from exc
    raise OptionError(owner, key, f"{key}: unsupported option type {hint}")


@dataclass(frozen=True, kw_only=True)
class SensorConfig:
    """Options every sensor has: a name, its mount (body + xyz/rpy offset), rate and frame.

    An empty `frame_id` or `topic` means the sensor type's default (see each sensor).
    """

    name: str
    body: str
    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)
    rate: float = 10.0
    frame_id: str = ""
    topic: str = ""

    def resolved_frame_id(self, suffix: str = "") -> str:
        """`frame_id` if given; else the body (or, when offset, the sensor name) + suffix."""
        if self.frame_id:
            return self.frame_id
        offset = any(self.xyz) or any(self.rpy)
        return (self.name if offset else self.body or "world") + suffix

    def mount(self) -> Mount:
        """The body and offset this sensor is attached to."""
        return Mount(self.body, self.xyz, self.rpy)

    @classmethod
    def from_config(cls, data: Mapping[str, Any]) -> Self:
        """Build from a scene-file mapping; a `type` key is ignored (the suite uses it).

        Unknown keys, missing required keys and badly typed values raise SimError
        naming the key and the valid choices.
        """
        hints = typing.get_type_hints(cls)
        known = {f.name: f for f in fields(cls)}
        owner = cls.__name__
        for key in data:
            if key not in known and key != "type":
                raise OptionError(
                    owner,
                    str(key),
                    f"unknown option '{key}'{did_you_mean(str(key), known)} "
                    f"(valid: {', '.join(sorted(known))})",
                )
        missing = [
            name
            for name, f in known.items()
            if f.default is MISSING and f.default_factory is MISSING and name not in data
        ]
        if missing:
            raise OptionError(
                owner,
                None,
                f"missing required option{'s' if len(missing) > 1 else ''} "
                f"{', '.join(map(repr, missing))}",
            )
        values = {
            key: _coerce(owner, key, hints[key], value)
            for key, value in data.items()
            if key != "type"
        }
        return cls(**values)
