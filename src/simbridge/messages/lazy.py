"""Definitions read but not parsed yet: user packages are parsed on first use.

Parsing a definition and building its classes costs about a millisecond per field, so
a `--msg-path` with large types would delay startup by seconds. `PendingSources` keeps
the texts and hands out, for one wanted type, it and every pending type it embeds.
"""

from __future__ import annotations

from simbridge.messages.loader import InterfaceSources

__all__ = ["MAX_DEFINITION_BYTES", "MAX_DEFINITION_FIELDS", "PendingSources"]

MAX_DEFINITION_FIELDS = 1000
"""Most field and constant lines one message definition may have."""
MAX_DEFINITION_BYTES = 256 * 1024
"""Largest text of one message definition."""

_BUILTIN = {
    "bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32",
    "int64", "uint64", "float32", "float64", "string", "time", "duration", "wstring",
}  # fmt: skip


class PendingSources:
    """Message texts and services waiting to be parsed, by canonical name."""

    __slots__ = ("messages", "services")

    def __init__(self) -> None:
        self.messages: dict[str, str] = {}
        self.services: dict[str, tuple[str, str]] = {}

    def add(self, sources: InterfaceSources) -> None:
        """Defer `sources` (later definitions of a name win)."""
        self.messages.update(sources.messages)
        self.services.update(sources.services)

    def take_message(self, canonical: str) -> InterfaceSources | None:
        """`canonical` and the pending types it embeds, removed from here; None if not here."""
        if canonical not in self.messages:
            return None
        wanted: dict[str, str] = {}
        todo = [canonical]
        while todo:
            name = todo.pop()
            if name in wanted or name not in self.messages:
                continue
            text = wanted[name] = self.messages[name]
            todo += _references(name, text)
        services = {srv: parts for srv, parts in self.services.items() if parts[0] in wanted}
        for name in wanted:
            del self.messages[name]
        for srv in services:
            del self.services[srv]
        return InterfaceSources(messages=wanted, services=services)

    def take_service(self, canonical: str) -> InterfaceSources | None:
        """Service `canonical` with its request, response and what they embed."""
        parts = self.services.get(canonical)
        if parts is None:
            return None
        merged = InterfaceSources(services={canonical: parts})
        for part in parts:
            found = self.take_message(part)
            if found is not None:
                merged.update(found)
        self.services.pop(canonical, None)
        return merged


def _references(owner: str, text: str) -> list[str]:
    """Canonical names of the message types a definition's fields use (a cheap scan)."""
    package = owner.split("/", 1)[0]
    found = []
    for line in text.splitlines():
        tokens = line.split("#", 1)[0].split()
        if len(tokens) != 2 or "=" in line:
            continue
        base = tokens[0].split("[", 1)[0]
        if base in _BUILTIN:
            continue
        if base == "Header":
            found.append("std_msgs/Header")
        elif "/" in base:
            parts = base.split("/")
            found.append(f"{parts[0]}/{parts[-1]}")
        else:
            found.append(f"{package}/{base}")
    return found
