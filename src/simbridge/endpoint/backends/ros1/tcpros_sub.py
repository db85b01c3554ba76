"""The endpoint's TCPROS subscriber connections: messages from ROS publishers, on the loop.

For each publisher the master names, one asyncio connection sends the subscriber
header, checks the publisher's answer (error, md5sum) and then hands every message's
bytes to the topic's callbacks right where they are parsed, with no thread hand-off.
When a consumer says it is blocked (its client stopped reading), the topic stops
reading from its publishers, so TCP pushes back on them instead of messages being
dropped here; reading resumes when the consumer catches up.

A publisher streaming small messages faster than the loop handles them would cost one
wake-up, one read and one write to each client per message or two. A connection whose
reads (each completing messages) keep coming less than `STREAM_GAP` after the previous
one was handled, or bring more than one message, `STREAM_READS` times in a row, is taken
as a stream: after each read it stops reading for `COALESCE` (about 1 ms with asyncio's
timers), so the next read takes what arrived meanwhile (the kernel holds it; TCP pushes
back if it must) and its messages leave to the clients in one write. It stays a stream
while those reads bring more than one message; meanwhile they are made straight from the
socket when a pause ends, the transport staying paused (no reader registered and removed
again per read). A message at a time, a request and its
reply, or a large message arriving in chunks never looks like a stream, so latency is
unchanged there; a stream's messages wait at most that pause.

A connection that drops (or cannot be made) while the master still lists its
publisher is retried with bounded exponential backoff, as rospy's subscriber does;
retrying stops when the master's publisher list no longer names it or the topic is
closed. Each episode is logged once when it starts and once when it ends, and
successful reconnects are counted.
"""

from __future__ import annotations

import asyncio
import logging
import os
import socket
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from simbridge.endpoint.backends.base import BatchCallback, MessageCallback
from simbridge.endpoint.backends.ros1.raw import RawMessageType
from simbridge.endpoint.backends.ros1.tcpros_pub import connection_ids
from simbridge.endpoint.speed.deferred import DeferredWrites, deferred_writes
from simbridge.protocol.tcpros import TcprosDecoder, TcprosError, encode_header

__all__ = ["Sink", "SubscribedTopic"]

_log = logging.getLogger("simbridge.endpoint.ros1")

CONNECT_TIMEOUT = 10.0
"""Seconds to connect to a publisher and get its header."""

RECHECK = 0.1
"""While reading is paused, how often to ask the consumers again whether they are blocked."""

RETRY_FIRST = 0.25
"""Seconds before the first attempt to reconnect to a publisher whose connection dropped."""

RETRY_MAX = 8.0
"""The longest wait between two reconnection attempts (the wait doubles after each)."""

STREAM_GAP = 100e-6
"""A read completing messages this soon after the previous one was handled counts towards
a stream (a reply to anything the endpoint sent takes longer to come back), as does one
completing more than one message."""
STREAM_READS = 3
"""Consecutive such reads after which a connection is taken as a stream and coalesced."""
_READ_SIZE = 256 * 1024
"""Bytes asked of the socket per read while a stream's reading is paused (asyncio's own
read size)."""

COALESCE = 0.0005
"""While a connection streams, reading pauses this long after each read (asyncio's timers
make it about 1 ms), so one read takes many messages instead of one wake-up each."""


@dataclass(eq=False, slots=True)
class Sink:
    """One consumer of a topic: its callback, optionally one for several messages at once
    (`batch`) and whether it is blocked now."""

    callback: MessageCallback
    blocked: Callable[[], bool] | None = None
    batch: BatchCallback | None = None


@dataclass(eq=False, slots=True)
class _Retry:
    """One episode of reconnecting to a listed publisher whose connection dropped."""

    host: str
    port: int
    delay: float = RETRY_FIRST
    attempts: int = 0
    timer: asyncio.TimerHandle | None = None


class SubscribedTopic:
    """One topic the endpoint subscribes to: its consumers and publisher connections."""

    def __init__(self, name: str, info: RawMessageType, callerid: str, max_message: int) -> None:
        self.name = name
        self.info = info
        self.callerid = callerid
        self.max_message = max_message
        self.sinks: list[Sink] = []
        self.connections: dict[str, _PublisherConnection] = {}
        self.errors = 0
        """Publisher connections that failed (refused, wrong md5sum, unreachable)."""
        self.reconnects = 0
        """Dropped publisher connections that were made again."""
        self.coalesced = 0
        """Pauses of a streaming connection's reading (see the module doc)."""
        self.publishers: frozenset[str] = frozenset()
        """The publishers' XML-RPC URIs, as the master last listed them."""
        self._retries: dict[str, _Retry] = {}
        self._closed = False
        self._tasks: set[asyncio.Task[None]] = set()
        self._recheck: asyncio.TimerHandle | None = None

    @property
    def closed(self) -> bool:
        return self._closed

    def header(self) -> bytes:
        """The subscriber header. It asks for Nagle's algorithm (`tcp_nodelay` 0, rospy's
        and roscpp's default): the publisher's kernel then joins a stream's small messages
        while the previous one is not yet acknowledged, instead of sending a segment per
        message (7-10 us of the publisher's CPU each, on loopback). A lone message or a
        reply goes out at once: the endpoint acknowledges what it reads as it reads it."""
        return encode_header(
            {
                "callerid": self.callerid,
                "md5sum": self.info.md5sum,
                "message_definition": self.info.definition,
                "tcp_nodelay": "0",
                "topic": self.name,
                "type": self.info.name,
            }
        )

    def connect(self, pub_uri: str, host: str, port: int) -> None:
        """Connect to the publisher at `host:port` unless connected to `pub_uri` already
        (a reconnection waiting for its turn goes now, to the address just negotiated)."""
        if self._closed or pub_uri in self.connections:
            return
        retry = self._retries.get(pub_uri)
        if retry is not None:
            if retry.timer is not None:
                retry.timer.cancel()
                retry.timer = None
            retry.host, retry.port = host, port
            retry.attempts += 1
        self._open(pub_uri, host, port)

    def _open(self, pub_uri: str, host: str, port: int) -> None:
        connection = _PublisherConnection(self, pub_uri, host, port)
        self.connections[pub_uri] = connection
        task = asyncio.get_running_loop().create_task(connection.open())
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    def set_publishers(self, uris: list[str]) -> None:
        """The master's current publisher list: stop reconnecting to those not in it."""
        self.publishers = frozenset(uris)
        for uri in list(self._retries):
            if uri not in self.publishers:
                self._stop_retrying(uri, "the master no longer lists it")

    def lost(self, connection: _PublisherConnection, reason: str) -> None:
        """`connection` dropped or could not be made: retry it while the master lists
        its publisher (unless it failed for good: refused, wrong type)."""
        self.forget(connection)
        uri = connection.pub_uri
        if uri in self.connections:  # an older connection: a newer one is on its way
            return
        retry = self._retries.get(uri)
        if self._closed or connection.final:
            self._stop_retrying(uri, None)
            return
        if uri not in self.publishers:
            if retry is not None:
                self._stop_retrying(uri, "the master no longer lists it")
            elif not connection.ready:
                self.errors += 1
                _log.warning("cannot receive %s from %s: %s", self.name, uri, reason)
            return
        if retry is None:
            if not connection.ready:
                self.errors += 1
            retry = _Retry(connection.host, connection.port)
            self._retries[uri] = retry
            _log.warning(
                "lost %s from %s (%s); reconnecting while the master lists it",
                self.name,
                uri,
                reason,
            )
        if retry.timer is None:
            loop = asyncio.get_running_loop()
            retry.timer = loop.call_later(retry.delay, self._retry, uri)
            retry.delay = min(retry.delay * 2, RETRY_MAX)

    def _retry(self, uri: str) -> None:
        retry = self._retries.get(uri)
        if retry is None or self._closed:
            return
        retry.timer = None
        if uri not in self.publishers:
            self._stop_retrying(uri, "the master no longer lists it")
        elif uri not in self.connections:
            retry.attempts += 1
            self._open(uri, retry.host, retry.port)

    def connected(self, connection: _PublisherConnection) -> None:
        """`connection`'s publisher answered: an episode of reconnecting ends here."""
        retry = self._retries.pop(connection.pub_uri, None)
        if retry is not None:
            self.reconnects += 1
            _log.info(
                "reconnected %s to %s after %d attempt(s)",
                self.name,
                connection.pub_uri,
                retry.attempts,
            )

    def _stop_retrying(self, uri: str, reason: str | None) -> None:
        retry = self._retries.pop(uri, None)
        if retry is None:
            return
        if retry.timer is not None:
            retry.timer.cancel()
        if reason is not None:
            _log.info(
                "stopped reconnecting %s to %s after %d attempt(s): %s",
                self.name,
                uri,
                retry.attempts,
                reason,
            )

    def deliver(self, queue: deque[bytes]) -> bool:
        """Hand the messages in `queue` to every consumer, in order, until one of them
        says it is blocked: then return True, leaving the rest in `queue`. A sole consumer
        that takes batches and is not blocked gets them in one call (it may take only the
        first ones, when it becomes blocked)."""
        sinks = self.sinks
        if len(sinks) == 1 and len(queue) > 1:
            sink = sinks[0]
            batch, blocked = sink.batch, sink.blocked
            if batch is not None and (blocked is None or not blocked()):
                taken = batch(queue)
                if taken >= len(queue):
                    queue.clear()
                    return blocked is not None and blocked()
                for _ in range(taken):
                    queue.popleft()
                return True  # it took only part: blocked
        if len(sinks) == 1:  # the usual case, without building a list per read
            blocked = sinks[0].blocked
            checks: tuple[Callable[[], bool], ...] = () if blocked is None else (blocked,)
        else:
            checks = tuple(sink.blocked for sink in sinks if sink.blocked is not None)
        while queue:
            if not sinks:
                queue.clear()
                break
            payload = queue.popleft()
            if len(sinks) == 1:
                sinks[0].callback(payload)
            else:
                for sink in list(sinks):
                    sink.callback(payload)
            for check in checks:
                if check():
                    return True
        return False

    def paused(self) -> None:
        """A connection stopped reading: ask again in a while (a consumer may give up
        being blocked without catching up, e.g. after its own time limit)."""
        if self._recheck is None and not self._closed:
            self._recheck = asyncio.get_running_loop().call_later(RECHECK, self.unblocked)

    def unblocked(self) -> None:
        """A consumer caught up: read from the publishers again if nobody is blocked."""
        if self._recheck is not None:
            self._recheck.cancel()
            self._recheck = None
        if self._closed:
            return
        if any(sink.blocked is not None and sink.blocked() for sink in self.sinks):
            self.paused()
            return
        for connection in list(self.connections.values()):
            connection.resume()

    def forget(self, connection: _PublisherConnection) -> None:
        if self.connections.get(connection.pub_uri) is connection:
            del self.connections[connection.pub_uri]

    def close(self) -> None:
        """Close every publisher connection; no more messages are delivered."""
        self._closed = True
        self.sinks.clear()
        if self._recheck is not None:
            self._recheck.cancel()
            self._recheck = None
        for uri in list(self._retries):
            self._stop_retrying(uri, None)
        for connection in list(self.connections.values()):
            connection.close()
        self.connections.clear()
        for task in list(self._tasks):
            task.cancel()


class _PublisherConnection(asyncio.Protocol):
    """One connection to a ROS publisher of the topic."""

    def __init__(self, topic: SubscribedTopic, pub_uri: str, host: str, port: int) -> None:
        self.topic = topic
        self.pub_uri = pub_uri
        self.host = host
        self.port = port
        self.id = next(connection_ids)
        self.ready = False
        """The publisher's header arrived and matched."""
        self.final = False
        """The publisher refused or sent the wrong type: never retried."""
        self._decoder = TcprosDecoder(topic.max_message)
        self._transport: asyncio.Transport | None = None
        self._reading_paused = False
        self._stash: deque[bytes] = deque()
        """Messages received but not yet delivered (at most one read's worth)."""
        self._writes: DeferredWrites | None = None
        self._handled = 0.0
        """When the last read was handled (time.monotonic())."""
        self._short = 0
        """Consecutive reads that looked like a stream's (see STREAM_GAP)."""
        self._loop = asyncio.get_running_loop()  # (made on the loop, by SubscribedTopic)
        self._fd = -1
        """The socket's descriptor, for a streaming connection's reads while paused."""
        self._coalescing: asyncio.TimerHandle | None = None
        """The end of the current pause of a streaming connection."""
        self._streaming = False

    async def open(self) -> None:
        loop = asyncio.get_running_loop()
        try:
            await asyncio.wait_for(
                loop.create_connection(lambda: self, self.host, self.port), CONNECT_TIMEOUT
            )
        except (OSError, TimeoutError) as exc:
            self.topic.lost(self, f"cannot connect to {self.host}:{self.port}: {exc}")

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        if self.topic.closed:
            transport.close()
            return
        self._transport = transport
        self._writes = deferred_writes(self._loop)
        sock = transport.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self._fd = sock.fileno()
        transport.write(self.topic.header())

    def data_received(self, data: bytes) -> None:
        writes = self._writes
        if writes is None:
            return
        start = time.monotonic()
        writes.hold()
        try:
            count = self._received(data)
        finally:
            writes.release()
        if count:
            self._pace(count, start)

    def _pace(self, count: int, start: float) -> None:
        """Take a read that completed `count` messages (begun at `start`) into account:
        pause reading after it while the connection streams (see the module doc)."""
        if self._streaming:
            if count > 1:
                self._coalesce()
            else:
                self._streaming = False
                self._short = 0
        elif count > 1 or start - self._handled < STREAM_GAP:
            self._short += 1
            if self._short >= STREAM_READS:
                self._streaming = True
                self._coalesce()
        else:
            self._short = 0
        self._handled = time.monotonic()

    def _coalesce(self) -> None:
        transport = self._transport
        if transport is None or self._reading_paused or self._coalescing is not None:
            return
        transport.pause_reading()  # (no-op while it stays paused from the last pause)
        self.topic.coalesced += 1
        self._coalescing = self._loop.call_later(COALESCE, self._coalesced)

    def _coalesced(self) -> None:
        """A streaming connection's pause ended: read what arrived straight from the
        socket (the transport stays paused, so no reader is registered and removed again
        for each read) and pause again while it streams; else read through the transport
        again (it also sees the end of the connection or an error itself)."""
        self._coalescing = None
        transport = self._transport
        if transport is None or self._reading_paused:
            return  # gone, or held by a blocked consumer (it resumes reading)
        if self._streaming and self._fd >= 0:
            try:
                data = os.read(self._fd, _READ_SIZE)
            except OSError:  # nothing yet (EAGAIN), or an error the transport will see
                data = b""
            if data:
                self.data_received(data)
                if self._coalescing is not None or self._transport is None:
                    return  # still a stream: paused again (or the connection failed)
        if not self._reading_paused:
            transport.resume_reading()

    def _received(self, data: bytes) -> int:
        """Hand what `data` completes to the consumers (what they write leaves when the
        caller releases the writes); returns how many messages it completed."""
        transport = self._transport
        if transport is None or transport.is_closing():
            return 0
        try:
            messages = self._decoder.feed(data)
        except TcprosError as exc:
            self._fail(str(exc))
            return 0
        if not self.ready:
            header = self._decoder.header
            if header is None:
                return 0
            if not self._check(header):
                return 0
            self.ready = True
            self.topic.connected(self)
        if messages:
            self._stash.extend(messages)
            if not self._reading_paused:
                self._pump()
        return len(messages)

    def _pump(self) -> None:
        """Deliver what was received; stop reading while a consumer is blocked."""
        transport = self._transport
        if transport is None:
            return
        if self.topic.deliver(self._stash):
            if not self._reading_paused:
                self._reading_paused = True
                transport.pause_reading()
            self.topic.paused()
        elif self._reading_paused:
            self._reading_paused = False
            transport.resume_reading()

    def _check(self, header: dict[str, str]) -> bool:
        if "error" in header:
            self._fail(f"the publisher refused: {header['error']}")
            return False
        md5sum = header.get("md5sum", "")
        if md5sum not in ("*", self.topic.info.md5sum):
            self._fail(
                f"the publisher's type is {header.get('type', '?')} (md5sum {md5sum}), "
                f"not {self.topic.info.name} ({self.topic.info.md5sum})"
            )
            return False
        return True

    def resume(self) -> None:
        """Deliver what is held and read again, unless a consumer is blocked again."""
        if self._reading_paused:
            self._pump()

    def _fail(self, reason: str) -> None:
        """The publisher's answer is unusable (an error, another type): give it up."""
        self.final = True
        self.topic.errors += 1
        if not self.topic.closed:
            _log.warning("cannot receive %s from %s: %s", self.topic.name, self.pub_uri, reason)
        self.close()
        self.topic.lost(self, reason)

    def close(self) -> None:
        if self._transport is not None:
            self._transport.close()

    def connection_lost(self, exc: Exception | None) -> None:
        self._transport = None
        if self._coalescing is not None:
            self._coalescing.cancel()
            self._coalescing = None
        self.topic.lost(self, str(exc) if exc is not None else "the publisher closed it")
