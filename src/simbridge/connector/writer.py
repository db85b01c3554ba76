"""The writer thread: drains the outgoing FIFO into the socket, many frames per syscall.

Small frames are packed into one buffer; a large payload goes to `sendmsg` as its own
buffer, so images are never copied on the way out. When nothing was sent for the
keepalive interval it sends the 8-byte keepalive.
"""

from __future__ import annotations

import logging
import struct
import threading
import time
from collections.abc import Sequence

from simbridge.connector.fifo import BoundedFifo
from simbridge.connector.link import Link
from simbridge.connector.stats import StatsCounters
from simbridge.protocol import KEEPALIVE

__all__ = ["FrameWriter", "OutTopic", "send_buffers"]

_log = logging.getLogger("simbridge.connector")
_pack_u32 = struct.Struct("<I").pack

_COPY_LIMIT = 64 * 1024
"""Payloads below this are copied into the shared batch buffer; larger ones are not."""
_BATCH_ITEMS = 8192
_BATCH_BYTES = 16 * 1024 * 1024
_IOV_MAX = 1024


class OutTopic:
    """An outgoing topic as the writer sees it: its name, framed prefix and queue bound."""

    __slots__ = ("bound", "prefix", "topic")

    def __init__(self, topic: str, prefix: bytes, bound: int) -> None:
        self.topic = topic
        self.prefix = prefix
        self.bound = bound


def send_buffers(link: Link, parts: Sequence[bytes | bytearray | memoryview]) -> int:
    """Write every buffer with as few `sendmsg` calls as possible; returns bytes sent."""
    pending: list[bytes | bytearray | memoryview] = list(parts)
    total = 0
    sock = link.sock
    with link.send_lock:
        while pending:
            chunk = pending[:_IOV_MAX]
            sent = sock.sendmsg(chunk)
            total += sent
            done = 0
            for buf in chunk:
                size = len(buf)
                if sent >= size:
                    sent -= size
                    done += 1
                    continue
                if sent:
                    pending[done] = memoryview(buf)[sent:]
                break
            del pending[:done]
    return total


class FrameWriter:
    """Owns the writer thread; `attach` gives it the current connection."""

    def __init__(
        self, fifo: BoundedFifo[OutTopic, bytes], counters: StatsCounters, keepalive: float
    ) -> None:
        self._fifo = fifo
        self._counters = counters
        self._keepalive = keepalive
        self._link: Link | None = None
        self._link_changed = threading.Event()
        self._stop = False
        self._busy = False
        self._thread = threading.Thread(
            target=self._run, name="simbridge-connector-writer", daemon=True
        )

    def start(self) -> None:
        """Start the thread."""
        self._thread.start()

    def attach(self, link: Link | None) -> None:
        """Write to `link` from now on (None: hold frames until the next one)."""
        self._link = link
        self._link_changed.set()

    def stop(self) -> None:
        """End the thread and wait for it."""
        self._stop = True
        self._link_changed.set()
        self._fifo.ready.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout=5.0)

    @property
    def idle(self) -> bool:
        """Nothing queued and nothing being written."""
        return not self._busy and len(self._fifo) == 0

    def _run(self) -> None:
        last_send = time.monotonic()
        fifo = self._fifo
        while not self._stop:
            link = self._link
            if link is None or link.broken.is_set():
                self._link_changed.wait()
                self._link_changed.clear()
                last_send = time.monotonic()
                continue
            fifo.ready.clear()  # anything queued after this sets it again
            if self._drain(link):
                last_send = time.monotonic()
                continue
            wait = self._keepalive - (time.monotonic() - last_send)
            if wait <= 0:
                if self._send(link, [KEEPALIVE], 1):
                    self._counters.keepalives_sent += 1
                last_send = time.monotonic()
            else:
                fifo.ready.wait(wait)

    def _drain(self, link: Link) -> bool:
        """Write batches until the FIFO is empty or the link changes; True if any was sent."""
        sent = False
        while not self._stop and self._link is link and not link.broken.is_set():
            self._busy = True
            try:
                batch = self._fifo.take(_BATCH_ITEMS, _BATCH_BYTES)
                if not batch:
                    break
                self._send(link, self._pack(batch), len(batch))
                sent = True
            finally:
                self._busy = False
        return sent

    @staticmethod
    def _pack(batch: list[tuple[OutTopic | None, bytes]]) -> list[bytes | bytearray]:
        parts: list[bytes | bytearray] = []
        small = bytearray()
        for key, item in batch:
            if key is None:
                small += item
                continue
            size = len(item)
            small += key.prefix
            small += _pack_u32(size)
            if size < _COPY_LIMIT:
                small += item
            else:
                parts.append(small)
                parts.append(item)
                small = bytearray()
        if small:
            parts.append(small)
        return parts

    def _send(self, link: Link, parts: list[bytes | bytearray] | list[bytes], frames: int) -> bool:
        try:
            sent = send_buffers(link, parts)
        except OSError as exc:
            if not link.broken.is_set():
                _log.warning("connection lost while sending: %s", exc)
            link.fail()
            return False
        self._counters.frames_sent += frames
        self._counters.bytes_sent += sent
        return True
