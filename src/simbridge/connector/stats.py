"""Counters of a connector and the immutable snapshot `Connector.stats()` returns."""

from __future__ import annotations

import threading
from collections import Counter
from dataclasses import dataclass, field

__all__ = ["ConnectorStats", "StatsCounters"]


@dataclass(frozen=True, slots=True)
class ConnectorStats:
    """What a connector has sent, received and lost since it was created.

    Frame counts treat a `__request`/`__response` header and its service frame as one.
    """

    frames_sent: int = 0
    bytes_sent: int = 0
    frames_received: int = 0
    bytes_received: int = 0
    keepalives_sent: int = 0
    publish_drops: dict[str, int] = field(default_factory=dict)
    """Outgoing messages dropped per topic because its queue was full."""
    subscribe_drops: dict[str, int] = field(default_factory=dict)
    """Received messages dropped per topic because callbacks fell behind."""
    connections: int = 0
    """Successful TCP connections (the first one included)."""
    reconnects: int = 0
    """Connections after the first."""
    logs_received: int = 0
    warnings_received: int = 0
    errors_received: int = 0
    callback_errors: int = 0
    """Exceptions raised by user callbacks and service handlers (logged)."""

    @property
    def total_publish_drops(self) -> int:
        """Sum of `publish_drops`."""
        return sum(self.publish_drops.values())


class StatsCounters:
    """Mutable counters. Each plain int has one writing thread (the `direct_` ones: the
    publishing thread holding the outgoing FIFO's lock); drop maps take a lock."""

    def __init__(self) -> None:
        self.frames_sent = 0
        self.bytes_sent = 0
        self.direct_frames_sent = 0
        self.direct_bytes_sent = 0
        """Written by publishing threads themselves (`FrameWriter.write_batch`)."""
        self.keepalives_sent = 0
        self.frames_received = 0
        self.bytes_received = 0
        self.connections = 0
        self.logs_received = 0
        self.warnings_received = 0
        self.errors_received = 0
        self._lock = threading.Lock()
        self._publish_drops: Counter[str] = Counter()
        self._subscribe_drops: Counter[str] = Counter()
        self._callback_errors = 0

    def publish_dropped(self, topic: str) -> None:
        """One outgoing message on `topic` was dropped."""
        with self._lock:
            self._publish_drops[topic] += 1

    def subscribe_dropped(self, topic: str) -> None:
        """One received message on `topic` was dropped before its callback ran."""
        with self._lock:
            self._subscribe_drops[topic] += 1

    def callback_failed(self) -> None:
        """A user callback raised."""
        with self._lock:
            self._callback_errors += 1

    def snapshot(self) -> ConnectorStats:
        """An immutable copy."""
        with self._lock:
            return ConnectorStats(
                frames_sent=self.frames_sent + self.direct_frames_sent,
                bytes_sent=self.bytes_sent + self.direct_bytes_sent,
                frames_received=self.frames_received,
                bytes_received=self.bytes_received,
                keepalives_sent=self.keepalives_sent,
                publish_drops=dict(self._publish_drops),
                subscribe_drops=dict(self._subscribe_drops),
                connections=self.connections,
                reconnects=max(0, self.connections - 1),
                logs_received=self.logs_received,
                warnings_received=self.warnings_received,
                errors_received=self.errors_received,
                callback_errors=self._callback_errors,
            )
