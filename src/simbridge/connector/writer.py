"""The writer thread: drains the outgoing FIFO into the socket, many frames per syscall.

Small frames are packed into one buffer; a large payload goes to `sendmsg` as its own
buffer, so images are never copied on the way out. When nothing was sent for the
keepalive interval it sends the 8-byte keepalive.

A batch of small frames (one simulation step's state messages) can skip the thread:
`write_batch` writes it from the publishing thread with one non-blocking `send` when
nothing is queued before it and the socket has room, so the writer thread is not woken
and the interpreter lock not handed over for every step. A single message published on
its own (`write_one`: a command, a ping) goes the same way, saving a thread hand-off on
each round trip; messages that follow each other closely are left to the writer thread,
which sends them many per syscall.
"""

from __future__ import annotations

import logging
import socket
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
_DIRECT_LIMIT = 64 * 1024
"""Batches up to this size may be written from the publishing thread (`write_batch`)."""
_BURST_GAP = 50e-6
"""A message published sooner than this after the previous one (`write_one`) is part of
a burst: it is queued for the writer thread, which sends a burst many frames per syscall."""


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
        self._direct_at = 0.0
        """When `write_batch` last wrote from a publishing thread (for the keepalive)."""
        self._published_at: float | None = None
        """When `write_one` last queued or wrote a message (to tell bursts apart); None
        before the first, which always stands alone."""
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
            if link is None or link.broken:
                self._link_changed.wait()
                self._link_changed.clear()
                last_send = time.monotonic()
                continue
            fifo.ready.clear()  # anything queued after this sets it again
            if self._drain(link):
                last_send = time.monotonic()
                continue
            wait = self._keepalive - (time.monotonic() - max(last_send, self._direct_at))
            if wait <= 0:
                if self._send(link, [KEEPALIVE], 1):
                    self._counters.keepalives_sent += 1
                last_send = time.monotonic()
            else:
                fifo.ready.wait(wait)

    def _drain(self, link: Link) -> bool:
        """Write batches until the FIFO is empty or the link changes; True if any was sent."""
        sent = False
        while not self._stop and self._link is link and not link.broken:
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

    def write_batch(self, entries: list[tuple[OutTopic, bytes, int]]) -> list[OutTopic]:
        """Queue published `(topic, payload, bound)` frames as one batch, or write them now.

        A small batch with nothing queued before it goes out with one non-blocking `send`
        on the calling thread (what the socket does not take is queued ahead of anything
        else); otherwise it is queued for the writer thread, which is woken once. Returns
        the topics that dropped a message (queue bound reached).
        """
        size = 0
        for _, payload, _ in entries:
            size += len(payload)
        if size > _DIRECT_LIMIT:
            return self._fifo.put_many(entries)
        return self._fifo.put_many_or_send(entries, self._send_now)

    def write_one(self, key: OutTopic, payload: bytes) -> bool:
        """Queue one published message, or write it now when it stands alone: small,
        published at least `_BURST_GAP` after the previous one, nothing queued before it
        and the writer thread idle. Returns True when the topic dropped a message."""
        now = time.monotonic()
        previous, self._published_at = self._published_at, now
        alone = previous is None or now - previous >= _BURST_GAP
        if alone and len(payload) <= _DIRECT_LIMIT:
            return bool(self._fifo.put_many_or_send([(key, payload, key.bound)], self._send_now))
        return self._fifo.put(key, payload, key.bound, len(payload))

    def _send_now(self, entries: Sequence[tuple[OutTopic, bytes, int]]) -> list[bytes] | None:
        """Write `entries` with one non-blocking send (the FIFO is empty and locked);
        None when that is not possible now, else the framed bytes left over."""
        link = self._link
        if self._busy or link is None or link.broken:
            return None
        lock = link.send_lock
        if not lock.acquire(blocking=False):  # the writer thread is sending (a keepalive)
            return None
        try:
            data = bytearray()
            for key, payload, _ in entries:
                data += key.prefix
                data += _pack_u32(len(payload))
                data += payload
            try:
                sent = link.sock.send(data, socket.MSG_DONTWAIT)
            except BlockingIOError:
                return None
            except OSError as exc:
                if not link.broken:
                    _log.warning("connection lost while sending: %s", exc)
                link.fail()
                return []  # lost with the connection, as a batch the writer thread sends
        finally:
            lock.release()
        self._direct_at = time.monotonic()
        counters = self._counters
        counters.direct_bytes_sent += sent
        if sent == len(data):
            counters.direct_frames_sent += len(entries)
            return []
        rest: list[bytes] = []
        start = 0
        for key, payload, _ in entries:  # whole frames count as sent; the rest is queued
            end = start + len(key.prefix) + 4 + len(payload)
            if end <= sent:
                counters.direct_frames_sent += 1
            else:
                rest.append(bytes(data[max(start, sent) : end]))
            start = end
        return rest

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
            if not link.broken:
                _log.warning("connection lost while sending: %s", exc)
            link.fail()
            return False
        self._counters.frames_sent += frames
        self._counters.bytes_sent += sent
        return True
