"""Scene YAML read with line numbers, so every error names the file, line and entry."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import yaml

from simbridge.errors import SimError

__all__ = ["LineList", "LineMap", "Where", "plain", "read_yaml"]


class LineMap(dict[Any, Any]):
    """A YAML mapping that knows the line it starts on and the line of each key."""

    def __init__(self, line: int = 0) -> None:
        super().__init__()
        self.line = line
        self.key_lines: dict[Any, int] = {}


class LineList(list[Any]):
    """A YAML sequence that knows the line it starts on and the line of each item."""

    def __init__(self, line: int = 0) -> None:
        super().__init__()
        self.line = line
        self.item_lines: list[int] = []


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader building LineMap and LineList instead of dict and list."""


def _mapping(loader: _Loader, node: yaml.MappingNode) -> Iterator[LineMap]:
    data = LineMap(node.start_mark.line + 1)
    yield data
    data.update(loader.construct_mapping(node))
    data.key_lines = {
        loader.construct_object(key): key.start_mark.line + 1 for key, _ in node.value
    }


def _sequence(loader: _Loader, node: yaml.SequenceNode) -> Iterator[LineList]:
    data = LineList(node.start_mark.line + 1)
    yield data
    data.extend(loader.construct_sequence(node))
    data.item_lines = [item.start_mark.line + 1 for item in node.value]


_Loader.add_constructor("tag:yaml.org,2002:map", _mapping)
_Loader.add_constructor("tag:yaml.org,2002:seq", _sequence)


def read_yaml(file: Path) -> object:
    """Parse a YAML file keeping line numbers; unreadable or malformed files raise SimError
    naming the file (and the line and column of a syntax error)."""
    try:
        text = file.read_text()
    except OSError as exc:
        raise SimError(f"scene file '{file}' cannot be read: {exc.strerror}") from None
    except UnicodeDecodeError as exc:
        raise SimError(f"scene file '{file}' is not UTF-8 text: {exc.reason}") from None
    try:
        return yaml.load(text, Loader=_Loader)  # a SafeLoader: no arbitrary objects
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        at = f"{file}:{mark.line + 1}:{mark.column + 1}" if mark is not None else str(file)
        what = "; ".join(str(part) for part in (exc.context, exc.problem) if part)
        raise SimError(f"{at}: not valid YAML: {what}") from None
    except yaml.YAMLError as exc:
        raise SimError(f"{file}: not valid YAML: {exc}") from None


def plain(value: Any) -> Any:
    """`value` with every LineMap and LineList turned back into a dict and a list."""
    if isinstance(value, dict):
        return {key: plain(item) for key, item in value.items()}
    if isinstance(value, list):
        return [plain(item) for item in value]
    return value


class Where(str):
    """An entry's path in a scene (`robots[0].base.xyz`) with the file and line it came
    from (None for a scene built from Python data); `error` words a SimError with both."""

    file: str | None
    line: int | None

    def __new__(cls, path: str, file: str | None = None, line: int | None = None) -> Where:
        where = super().__new__(cls, path)
        where.file = file
        where.line = line
        return where

    def child(self, suffix: str, line: int | None = None) -> Where:
        """The path of a part of this entry (`.name` or `[i]`), on `line` if known."""
        return Where(f"{self}{suffix}", self.file, line or self.line)

    def at(self, line: int | None) -> Where:
        """This entry with the error pointing at `line` (e.g. the line of a bad key)."""
        return Where(str(self), self.file, line or self.line)

    def error(self, message: str) -> SimError:
        """`file:line: entry: message` (`scene entry: message` without a file)."""
        entry = str(self) or "top level"
        if self.file is None:
            return SimError(f"scene {entry}: {message}")
        at = f"{self.file}:{self.line}" if self.line else self.file
        return SimError(f"{at}: {entry}: {message}")
