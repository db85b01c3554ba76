"""What the endpoint sends one client, bounded: writes joined per read, frames that must not
be dropped (held while the client does not read, up to a limit), and each subscription's
queue, which drops its oldest messages once full and says so in a `__warn`."""

from __future__ import annotations

import asyncio
import logging
import struct
import time
from collections import deque
from collections.abc import Callable, Sequence

from simbridge.endpoint.budget import MemoryShare
from simbridge.endpoint.options import EndpointOptions
from simbridge.endpoint.session.stats import SessionStats
from simbridge.endpoint.speed.deferred import deferred_writes
from simbridge.endpoint.speed.writev import WRITE_ALONE, write_chunks
from simbridge.protocol import KEEPALIVE, WarnMessage, shorten

__all__ = ["BLOCK_LIMIT", "ClientOutput", "Outbox"]

log = logging.getLogger("simbridge.endpoint")
_pack_u32 = struct.Struct("<I").pack

_ENTRY_OVERHEAD = 64
"""Bytes a queued message costs beyond its payload (object header, queue slot), charged to
the memory budget so a million empty messages are not free."""

BLOCK_LIMIT = 2.0
"""Seconds a subscription may push back on its ROS publishers while its client is not
reading, before its messages are dropped (past its queue_size) instead."""


class Outbox:
    """A subscription's bounded queue, used only while the client is not keeping up."""

    __slots__ = ("prefix", "queue", "size", "topic")

    def __init__(self, topic: str, size: int) -> None:
        self.topic = topic
        dest = topic.encode()
        self.prefix = _pack_u32(len(dest)) + dest
        self.queue: deque[bytes] = deque()
        self.size = max(1, size)


class ClientOutput:
    """The output side of one client connection. `close` is called when the client has
    stopped reading for so long that a frame which may not be dropped does not fit."""

    def __init__(
        self,
        options: EndpointOptions,
        memory: MemoryShare,
        stats: SessionStats,
        loop: asyncio.AbstractEventLoop,
        close: Callable[[], None],
    ) -> None:
        self._options = options
        self._memory = memory
        self._stats = stats
        self._loop = loop
        self._close = close
        self._transport: asyncio.Transport | None = None
        self._fd = -1
        """The socket's descriptor, for scatter-gather writes while the transport is idle."""
        self._peer = "?"
        self._out: list[bytes | memoryview] = []
        self._out_size = 0
        self._flush_scheduled = False
        self._writes = deferred_writes(loop)
        """Writes leave at the end of the read that caused them (or of the loop iteration)."""
        self._paused = False
        self._paused_at = 0.0
        self._control: deque[bytes] = deque()
        self._backlogged: dict[str, Outbox] = {}
        self._closing = False
        self._warn_scheduled = False
        self._reported_drops = 0
        self.last_sent = time.monotonic()

    def attach(self, transport: asyncio.Transport, fd: int, peer: str) -> None:
        """The connection is made: write to `transport` (socket `fd`, -1 if unknown)."""
        self._transport, self._fd, self._peer = transport, fd, peer

    @property
    def paused(self) -> bool:
        """Whether the transport asked to stop writing (the client is not reading)."""
        return self._paused

    def pause(self) -> None:
        """The transport's buffer is full: hold what follows."""
        self._paused = True
        self._paused_at = time.monotonic()

    def resume(self) -> bool:
        """The transport has room again: send what was held; whether it all went."""
        self._paused = False
        self._drain_backlog()
        return not self._paused

    def blocked(self, outbox: Outbox) -> bool:
        """Whether the backend should stop taking `outbox`'s topic from the graph: the
        client is not reading and its queue is half full, for at most BLOCK_LIMIT seconds
        (past that the client is slow, not momentarily busy, and drops are its own)."""
        if not self._paused or len(outbox.queue) * 2 < outbox.size:
            return False
        return time.monotonic() - self._paused_at < BLOCK_LIMIT

    def _write(self, chunk: bytes | memoryview) -> None:
        self._out.append(chunk)
        self._out_size += len(chunk)
        if self._out_size >= self._options.write_high_water:
            self._flush()
        elif not self._flush_scheduled:
            self._flush_scheduled = True
            self._writes.defer(self._flush)

    def _flush(self) -> None:
        self._flush_scheduled = False
        out, self._out = self._out, []
        size, self._out_size = self._out_size, 0
        transport = self._transport
        if not out or transport is None or transport.is_closing():
            return
        self.last_sent = time.monotonic()
        self._stats.bytes_out += size
        write_chunks(transport, self._fd, out)

    def send_control(self, frame: bytes) -> None:
        """Send a frame that must not be dropped (handshake, service frames, errors)."""
        if self._closing:
            return
        self._stats.frames_out += 1
        if not self._paused:
            self._write(frame)
            return
        if len(self._control) >= self._options.max_control_backlog or not self._memory.take(
            len(frame)
        ):
            log.error(
                "client %s stopped reading; %d control frames (%d bytes held) queued, "
                "disconnecting",
                self._peer,
                len(self._control),
                self._memory.held,
            )
            self._close()
            return
        self._control.append(frame)

    def send_keepalive_if_idle(self, now: float) -> None:
        """A keepalive when nothing was sent for the keepalive interval."""
        if now - self.last_sent >= self._options.keepalive_interval and not self._paused:
            self._write(KEEPALIVE)
            self.last_sent = now

    def deliver(self, outbox: Outbox, payload: bytes) -> None:
        """Queue one subscribed message, dropping the oldest when the client lags."""
        if self._closing:
            return
        if not self._paused:
            self._stats.frames_out += 1
            size = len(payload)
            if size < WRITE_ALONE:
                self._write(outbox.prefix + _pack_u32(size) + payload)
            else:
                self._write(outbox.prefix + _pack_u32(size))
                self._write(payload)
            return
        queue = outbox.queue
        memory = self._memory
        size = len(payload) + _ENTRY_OVERHEAD
        while queue and (len(queue) >= outbox.size or not memory.fits(size)):
            memory.give(len(queue.popleft()) + _ENTRY_OVERHEAD)
            self._dropped(outbox.topic)
        if not memory.take(size):
            self._dropped(outbox.topic)  # alone it does not fit this client's share
            return
        queue.append(payload)
        self._backlogged[outbox.topic] = outbox

    def deliver_lent(self, outbox: Outbox, view: memoryview) -> None:
        """`deliver` for a payload the backend lends for this call only (it reuses the
        memory afterwards). While the client reads, a large one is written now, straight
        from the view (what the kernel does not take at once goes to the transport's
        buffer, copied); anything kept for later is copied first."""
        size = len(view)
        if self._paused or self._closing or size < WRITE_ALONE:
            self.deliver(outbox, bytes(view))
            return
        self._stats.frames_out += 1
        self._write(outbox.prefix + _pack_u32(size))
        self._write(view)
        self._flush()

    def deliver_many(self, outbox: Outbox, payloads: Sequence[bytes]) -> int:
        """Queue subscribed messages that arrived together; returns how many it took. While
        the client reads, small ones leave as one joined chunk (one frame header built for
        a run of one size); otherwise each goes through `deliver`, stopping once the topic
        should push back on its publishers (`blocked`)."""
        if not payloads:
            return 0
        if not self._paused and not self._closing:
            sizes = set(map(len, payloads))
            if max(sizes) < WRITE_ALONE:
                self._stats.frames_out += len(payloads)
                prefix = outbox.prefix
                if len(sizes) == 1:
                    head = prefix + _pack_u32(sizes.pop())
                    self._write(head + head.join(payloads))
                else:
                    self._write(b"".join([prefix + _pack_u32(len(p)) + p for p in payloads]))
                return len(payloads)
        taken = 0
        for payload in payloads:
            self.deliver(outbox, payload)
            taken += 1
            if self.blocked(outbox):
                break
        return taken

    def drop(self, outbox: Outbox) -> None:
        """The subscription is gone: forget what its queue holds."""
        self._backlogged.pop(outbox.topic, None)
        queue = outbox.queue
        self._memory.give(sum(map(len, queue)) + _ENTRY_OVERHEAD * len(queue))
        queue.clear()

    def _dropped(self, topic: str) -> None:
        self._stats.dropped[topic] += 1
        if not self._warn_scheduled:
            self._warn_scheduled = True
            self._loop.call_later(self._options.warn_interval, self._warn_drops)

    def _drain_backlog(self) -> None:
        while self._control and not self._paused:
            frame = self._control.popleft()
            self._memory.give(len(frame))
            self._write(frame)
        while self._backlogged and not self._paused:
            for key, outbox in list(self._backlogged.items()):
                if self._paused:
                    break
                if outbox.queue:
                    payload = outbox.queue.popleft()
                    self._memory.give(len(payload) + _ENTRY_OVERHEAD)
                    self._stats.frames_out += 1
                    self._write(outbox.prefix + _pack_u32(len(payload)))
                    self._write(payload)
                    self._flush()
                if not outbox.queue:
                    del self._backlogged[key]

    def _warn_drops(self) -> None:
        """One `__warn` per interval with every drop since the last one."""
        self._warn_scheduled = False
        dropped = self._stats.dropped
        total = sum(dropped.values())
        new = total - self._reported_drops
        if not new or self._closing:
            return
        self._reported_drops = total
        detail = ", ".join(f"{shorten(t)}: {n}" for t, n in dropped.most_common(5))
        self.send_control(
            WarnMessage(
                f"client is not keeping up: dropped {new} message(s) since the last warning "
                f"({total} in all; per topic {detail}); raise queue_size or read faster"
            ).encode()
        )

    def stop(self) -> None:
        """Nothing more is queued for the client."""
        self._closing = True

    def close(self) -> None:
        """Stop, and hand the transport what is queued (a last `__error`) before closing it."""
        self._closing = True
        if self._transport is not None:
            self._flush()
            self._transport.close()

    def discard(self) -> None:
        """The connection is gone: forget what was held for it."""
        self._control.clear()
        self._backlogged.clear()
