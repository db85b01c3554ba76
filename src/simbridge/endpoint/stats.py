"""Counters an endpoint keeps per client, visible through `__stats` and logs."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

__all__ = ["SessionStats"]


@dataclass(slots=True)
class SessionStats:
    """What one client connection moved, dropped and got wrong."""

    frames_in: int = 0
    bytes_in: int = 0
    frames_out: int = 0
    bytes_out: int = 0
    errors_sent: int = 0
    dropped: Counter[str] = field(default_factory=Counter)
    """Messages dropped per topic because the client fell behind its queue_size."""

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {
            "frames_in": self.frames_in,
            "bytes_in": self.bytes_in,
            "frames_out": self.frames_out,
            "bytes_out": self.bytes_out,
            "errors_sent": self.errors_sent,
            "dropped": dict(self.dropped),
            "dropped_total": sum(self.dropped.values()),
        }
