"""A YAML mapping of the `perception:` section with its place in the scene file, and typed
getters whose errors name the file, line, entry, the bad value and what was expected."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from simbridge.errors import PerceptionError, did_you_mean
from simbridge.sim.scene.located import LineList, LineMap, Where

__all__ = ["Range", "Section"]

Range = tuple[float, float]
"""A closed interval [low, high] a randomiser draws from uniformly."""


def _kind(value: object) -> str:
    if isinstance(value, Mapping):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    return repr(value)


class Section:
    """One mapping of the section; `where` is its path (`perception.cameras[0]`)."""

    def __init__(self, data: object, where: Where) -> None:
        if data is None:
            data = {}
        if not isinstance(data, Mapping):
            raise self._error(where, f"expected a mapping of keys, got {_kind(data)}")
        self.data: Mapping[str, Any] = data
        self.where = where

    @staticmethod
    def _error(where: Where, message: str) -> PerceptionError:
        return PerceptionError(str(where.error(message)))

    def error(self, message: str, key: str | None = None) -> PerceptionError:
        """An error at this entry (at `key`'s line when given)."""
        return self._error(self.key(key) if key is not None else self.where, message)

    def key(self, name: str) -> Where:
        line = self.data.key_lines.get(name) if isinstance(self.data, LineMap) else None
        return self.where.child(f".{name}", line)

    def has(self, name: str) -> bool:
        return self.data.get(name) is not None

    def done(self, known: Sequence[str]) -> None:
        """Every key must be one of `known`."""
        for key in self.data:
            if key not in known:
                raise self.error(
                    f"unknown key '{key}'{did_you_mean(str(key), known)} "
                    f"(valid: {', '.join(known)})",
                    str(key),
                )

    def sub(self, name: str) -> Section:
        return Section(self.data.get(name), self.key(name))

    def items(self, name: str) -> list[Section]:
        value = self.data.get(name) or []
        where = self.key(name)
        if not isinstance(value, list):
            raise self._error(where, f"expected a list of entries, got {_kind(value)}")
        lines = value.item_lines if isinstance(value, LineList) else [None] * len(value)
        return [
            Section(v, where.child(f"[{i}]", line))
            for i, (v, line) in enumerate(zip(value, lines, strict=True))
        ]

    # ---- typed values --------------------------------------------------------------------

    def _number(self, value: Any, where: Where) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self._error(where, f"expected a number, got {_kind(value)}")
        if not math.isfinite(value):
            raise self._error(where, f"expected a finite number, got {value!r}")
        return float(value)

    def number(
        self, name: str, default: float, low: float | None = None, high: float | None = None
    ) -> float:
        """A number in [low, high] (either bound optional)."""
        if not self.has(name):
            return default
        value = self._number(self.data[name], self.key(name))
        self._check_bounds(name, value, low, high)
        return value

    def _check_bounds(self, name: str, value: float, low: float | None, high: float | None) -> None:
        if (low is not None and value < low) or (high is not None and value > high):
            lo = "-inf" if low is None else f"{low:g}"
            hi = "inf" if high is None else f"{high:g}"
            raise self.error(f"{value:g} is out of range (expected [{lo}, {hi}])", name)

    def integer(
        self, name: str, default: int, low: int | None = None, high: int | None = None
    ) -> int:
        """A whole number in [low, high] (either bound optional)."""
        if not self.has(name):
            return default
        value = self.data[name]
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(f"expected a whole number, got {_kind(value)}", name)
        self._check_bounds(name, value, low, high)
        return value

    def boolean(self, name: str, default: bool) -> bool:
        if not self.has(name):
            return default
        value = self.data[name]
        if not isinstance(value, bool):
            raise self.error(f"expected true or false, got {_kind(value)}", name)
        return value

    def string(self, name: str, default: str) -> str:
        if not self.has(name):
            return default
        value = self.data[name]
        if not isinstance(value, str) or not value:
            raise self.error(f"expected a non-empty string, got {_kind(value)}", name)
        return value

    def choice(self, name: str, valid: Sequence[str], default: str) -> str:
        value = self.string(name, default)
        if value not in valid:
            raise self.error(
                f"expected one of {', '.join(valid)}, got {value!r}{did_you_mean(value, valid)}",
                name,
            )
        return value

    def strings(self, name: str, default: Sequence[str] = ()) -> tuple[str, ...]:
        """A list of strings (a single string is a list of one)."""
        if not self.has(name):
            return tuple(default)
        value = self.data[name]
        if isinstance(value, str):
            value = [value]
        if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
            raise self.error(f"expected a list of names, got {_kind(value)}", name)
        return tuple(value)

    def vector(self, name: str, count: int, default: Sequence[float]) -> tuple[float, ...]:
        if not self.has(name):
            return tuple(default)
        value = self.data[name]
        where = self.key(name)
        if not isinstance(value, list | tuple) or len(value) != count:
            raise self._error(where, f"expected a list of {count} numbers, got {value!r}")
        return tuple(self._number(v, where.child(f"[{i}]")) for i, v in enumerate(value))

    def range(
        self, name: str, default: Range, low: float | None = None, high: float | None = None
    ) -> Range:
        """`[low, high]` (or one number: a fixed value) within the bounds given."""
        if not self.has(name):
            return default
        value = self.data[name]
        if isinstance(value, int | float) and not isinstance(value, bool):
            lo = hi = self._number(value, self.key(name))
        elif isinstance(value, list):
            lo, hi = self.vector(name, 2, default)
        else:
            raise self.error(f"expected [low, high] or a number, got {_kind(value)}", name)
        if lo > hi:
            raise self.error(f"low {lo:g} is above high {hi:g}", name)
        self._check_bounds(name, lo, low, high)
        self._check_bounds(name, hi, low, high)
        return (lo, hi)
