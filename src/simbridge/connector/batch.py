"""One thread's publishes gathered and handed to the writer at once (`Connector.batch`).

A simulation step may publish several small messages (joint states, TF, /clock, sensor
readings). Queued one by one, each takes the FIFO's lock and may wake the writer thread,
which then competes with the simulation for the interpreter lock. Inside a batch they
are collected and leave together when it ends: one lock, at most one wake-up, and
usually none, since `FrameWriter.write_batch` writes a small batch straight into the
socket when nothing waits before it.
"""

from __future__ import annotations

import threading
from types import TracebackType

from simbridge.connector.stats import StatsCounters
from simbridge.connector.writer import FrameWriter, OutTopic

__all__ = ["PublishBatch"]


class _ThreadBatch(threading.local):
    """One thread's open batch: its messages (None outside one) and how deeply nested."""

    pending: list[tuple[OutTopic, bytes, int]] | None = None
    depth = 0


class PublishBatch:
    """A reusable, re-entrant context manager; batches are per thread (publishes from
    other threads meanwhile are queued as usual), and the outermost `with` sends."""

    def __init__(self, writer: FrameWriter, counters: StatsCounters) -> None:
        self._writer = writer
        self._counters = counters
        self._local = _ThreadBatch()

    @property
    def writer(self) -> FrameWriter:
        """The writer the batches go to (single publishes use it too: `write_one`)."""
        return self._writer

    def pending(self) -> list[tuple[OutTopic, bytes, int]] | None:
        """The calling thread's open batch (None outside one)."""
        return self._local.pending

    def send_pending(self) -> None:
        """Send what the calling thread's open batch holds so far (before a command that
        must follow those messages, such as `__remove_publisher`); the batch stays open."""
        pending = self.pending()
        if pending:
            self._local.pending = []
            self._send(pending)

    def _send(self, entries: list[tuple[OutTopic, bytes, int]]) -> None:
        for out in self._writer.write_batch(entries):
            self._counters.publish_dropped(out.topic)

    def __enter__(self) -> PublishBatch:
        local = self._local
        depth = local.depth
        if depth == 0:
            local.pending = []
        local.depth = depth + 1
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        local = self._local
        local.depth -= 1
        if local.depth:
            return
        entries = local.pending
        local.pending = None
        if entries:
            self._send(entries)
