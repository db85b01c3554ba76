"""The endpoint's own TCPROS server: ROS subscribers of its topics connect here.

Runs on the endpoint's event loop, so a publish is a few appends and one write per
connection per read of the client's frames (everything one read brings in goes out in
one `write`, right at the end of that read: see `endpoint.deferred`), with no thread
hand-off. A connection whose kernel buffer is full holds its
messages in a queue bounded by the registration's `queue_size` (and a byte cap);
past that the oldest are dropped and counted, as rospy's publisher queue does.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import socket
import struct
from collections import deque
from collections.abc import Callable

from simbridge.endpoint.backends.ros1_raw import RawMessageType
from simbridge.endpoint.deferred import DeferredWrites, deferred_writes
from simbridge.endpoint.writev import write_chunks
from simbridge.protocol.tcpros import TcprosDecoder, TcprosError, encode_header

__all__ = ["PublishedTopic", "TopicServer", "connection_ids"]

_log = logging.getLogger("simbridge.endpoint.ros1")

HEADER_TIMEOUT = 10.0
"""Seconds a new connection has to send its header."""

MAX_HELD_BYTES = 512 << 20
"""Bytes one connection may hold while its subscriber is not reading (queue_size 0 is
unbounded in count, as in rospy, but not in bytes)."""

WRITE_HIGH_WATER = 1 << 20
"""Bytes asyncio may buffer for one connection before the endpoint holds messages itself."""


_U32 = struct.Struct("<I")

connection_ids = itertools.count(1 << 20)
"""Ids of the endpoint's TCPROS connections in getBusInfo (apart from rospy's own)."""

_FLUSH_AT = 256 << 10
"""Bytes queued for one connection that are written at once rather than when the read
that published them is done."""


class PublishedTopic:
    """One topic the endpoint publishes: its subscribers' connections and latched message."""

    def __init__(
        self, server: TopicServer, name: str, info: RawMessageType, latch: bool, queue_size: int
    ) -> None:
        self.server = server
        self.name = name
        self.info = info
        self.latch = latch
        self.queue_size = queue_size
        self.refs = 0
        self.connections: list[_SubscriberConnection] = []
        self.latched: tuple[bytes, bytes] | None = None
        """The length prefix and payload of the last message, when latching."""
        self.dropped = 0
        self.watchers: list[Callable[[int], None]] = []

    def publish(self, payload: bytes) -> None:
        """Send one serialized message to every connected subscriber."""
        prefix = _U32.pack(len(payload))
        if self.latch:
            self.latched = (prefix, payload)
        for connection in self.connections:
            connection.send(prefix, payload)

    def header(self, callerid: str) -> bytes:
        """The header this publisher answers a subscriber with."""
        return encode_header(
            {
                "callerid": callerid,
                "latching": "1" if self.latch else "0",
                "md5sum": self.info.md5sum,
                "message_definition": self.info.definition,
                "topic": self.name,
                "type": self.info.name,
            }
        )

    def _changed(self) -> None:
        count = len(self.connections)
        for callback in list(self.watchers):
            callback(count)

    def add(self, connection: _SubscriberConnection) -> None:
        self.connections.append(connection)
        if self.latched is not None:
            connection.send(*self.latched)
        self._changed()

    def remove(self, connection: _SubscriberConnection) -> None:
        if connection in self.connections:
            self.connections.remove(connection)
            self._changed()

    def close(self) -> None:
        """Close every connection (the topic is no longer published)."""
        for connection in list(self.connections):
            connection.close()
        self.connections.clear()
        self.watchers.clear()


class TopicServer:
    """Accepts TCPROS subscriber connections for the topics in `topics`."""

    def __init__(self, callerid: str, max_message: int) -> None:
        self.callerid = callerid
        self.max_message = max_message
        self.topics: dict[str, PublishedTopic] = {}
        self.refused = 0
        """Connections refused (bad header, unknown topic, wrong md5sum)."""
        self.dropped = 0
        """Messages dropped for ROS subscribers that did not keep up (past queue_size)."""
        self._server: asyncio.Server | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._writes: DeferredWrites | None = None
        self._dirty: list[_SubscriberConnection] = []
        self._connections: set[_SubscriberConnection] = set()
        self.port = 0

    async def start(self, bind_host: str) -> None:
        """Listen on `bind_host` at a free port."""
        self._loop = asyncio.get_running_loop()
        self._writes = deferred_writes(self._loop)
        self._server = await self._loop.create_server(
            lambda: _SubscriberConnection(self), bind_host, 0
        )
        self.port = self._server.sockets[0].getsockname()[1]

    def close(self) -> None:
        """Stop listening and close every connection."""
        if self._server is not None:
            self._server.close()
            self._server = None
        for topic in list(self.topics.values()):
            topic.close()
        self.topics.clear()
        for connection in list(self._connections):
            connection.close()

    def publication(
        self, name: str, info: RawMessageType, latch: bool, queue_size: int
    ) -> PublishedTopic:
        """The shared PublishedTopic for `name` (one more user of it)."""
        topic = self.topics.get(name)
        if topic is None:
            topic = PublishedTopic(self, name, info, latch, queue_size)
            self.topics[name] = topic
        else:
            topic.latch = topic.latch or latch
            topic.queue_size = max(topic.queue_size, queue_size)
        topic.refs += 1
        return topic

    def release(self, topic: PublishedTopic) -> None:
        """One user of `topic` is gone; the last closes it."""
        topic.refs -= 1
        if topic.refs <= 0 and self.topics.get(topic.name) is topic:
            del self.topics[topic.name]
            topic.close()

    def schedule(self, connection: _SubscriberConnection) -> None:
        """Flush `connection` once the read that published to it is done (or at the end
        of this loop iteration)."""
        if not self._dirty and self._writes is not None:
            self._writes.defer(self._flush)
        self._dirty.append(connection)

    def _flush(self) -> None:
        dirty, self._dirty = self._dirty, []
        for connection in dirty:
            connection.flush()


class _SubscriberConnection(asyncio.Protocol):
    """One ROS subscriber connected to the server: header exchange, then outgoing frames."""

    def __init__(self, server: TopicServer) -> None:
        self._server = server
        self._decoder = TcprosDecoder(server.max_message)
        self._transport: asyncio.Transport | None = None
        self._topic: PublishedTopic | None = None
        self._pending: list[bytes] = []
        self._pending_bytes = 0
        self._fd = -1
        self._held: deque[tuple[bytes, bytes]] = deque()
        self._held_bytes = 0
        self._paused = False
        self._timer: asyncio.TimerHandle | None = None
        self.peer = "?"
        self.callerid = "?"
        """The subscriber node, from its header."""
        self.id = next(connection_ids)

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self._transport = transport
        self._server._connections.add(self)
        # Resume only once asyncio holds nothing, so the next messages go out with one
        # writev from their own bytes; the kernel's socket buffer keeps the link busy.
        transport.set_write_buffer_limits(high=WRITE_HIGH_WATER, low=0)
        sock = transport.get_extra_info("socket")
        self._fd = sock.fileno() if sock is not None else -1
        peer = transport.get_extra_info("peername")
        self.peer = f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) else str(peer)
        loop = asyncio.get_running_loop()
        self._timer = loop.call_later(HEADER_TIMEOUT, self._header_timeout)

    def _header_timeout(self) -> None:
        if self._topic is None:
            self._refuse(f"no connection header within {HEADER_TIMEOUT} s")

    def data_received(self, data: bytes) -> None:
        if self._topic is not None or self._transport is None or self._transport.is_closing():
            return  # subscribers send nothing after their header
        try:
            self._decoder.feed(data)
        except TcprosError as exc:
            self._refuse(f"bad connection header from {self.peer}: {exc}")
            return
        header = self._decoder.header
        if header is not None:
            self._accept(header)

    def _accept(self, header: dict[str, str]) -> None:
        if self._timer is not None:
            self._timer.cancel()
        if "service" in header:
            self._refuse("this port serves topics only; services are on the node's rospy port")
            return
        for required in ("topic", "md5sum", "callerid"):
            if required not in header:
                self._refuse(f"missing required {required!r} field")
                return
        name = header["topic"]
        topic = self._server.topics.get(name)
        if topic is None:
            self._refuse(f"[{self._server.callerid}] is not a publisher of [{name}]")
            return
        md5sum = header["md5sum"]
        if md5sum not in ("*", topic.info.md5sum):
            wanted = header.get("type", topic.info.name)
            if wanted not in ("*", topic.info.name):
                self._refuse(f"topic types do not match: [{wanted}] vs. [{topic.info.name}]")
            else:
                self._refuse(
                    f"Client [{header['callerid']}] wants topic [{name}] to have datatype/md5sum "
                    f"[{wanted}/{md5sum}], but our version has "
                    f"[{topic.info.name}/{topic.info.md5sum}] Dropping connection."
                )
            return
        transport = self._transport
        assert transport is not None
        if header.get("tcp_nodelay", "0").strip() == "1":
            sock = transport.get_extra_info("socket")
            if sock is not None:
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        transport.write(topic.header(self._server.callerid))
        self.callerid = header["callerid"]
        self._topic = topic
        topic.add(self)
        _log.debug("%s subscribed to %s from %s", header["callerid"], name, self.peer)

    def _refuse(self, reason: str) -> None:
        self._server.refused += 1
        _log.warning("refused a TCPROS connection from %s: %s", self.peer, reason)
        if self._transport is not None and not self._transport.is_closing():
            self._transport.write(encode_header({"error": reason}))
            self._transport.close()

    def send(self, prefix: bytes, payload: bytes) -> None:
        """Queue one message (its length prefix and bytes); it leaves once the read that
        published it is done, or is held while the subscriber is not reading."""
        if self._paused:
            self._hold(prefix, payload)
            return
        if not self._pending:
            self._server.schedule(self)
        self._pending.append(prefix)
        self._pending.append(payload)
        self._pending_bytes += len(prefix) + len(payload)
        if self._pending_bytes >= _FLUSH_AT:
            self.flush()  # the transport pauses us if its buffer is full

    def _hold(self, prefix: bytes, payload: bytes) -> None:
        topic = self._topic
        assert topic is not None
        limit = topic.queue_size
        held = self._held
        size = len(prefix) + len(payload)
        while held and (
            (limit > 0 and len(held) >= limit) or self._held_bytes + size > MAX_HELD_BYTES
        ):
            old_prefix, old_payload = held.popleft()
            self._held_bytes -= len(old_prefix) + len(old_payload)
            topic.dropped += 1
            self._server.dropped += 1
        held.append((prefix, payload))
        self._held_bytes += size

    def flush(self) -> None:
        """Write what was queued: with one scatter-gather syscall straight from the
        messages' bytes while the transport holds nothing, the rest through the transport
        (small pieces joined, large ones on their own)."""
        pending, self._pending = self._pending, []
        self._pending_bytes = 0
        transport = self._transport
        if transport is None or transport.is_closing() or not pending:
            return
        write_chunks(transport, self._fd, pending)

    def pause_writing(self) -> None:
        self._paused = True

    def resume_writing(self) -> None:
        self._paused = False
        held = self._held
        while held and not self._paused:
            prefix, payload = held.popleft()
            self._held_bytes -= len(prefix) + len(payload)
            self._pending.append(prefix)
            self._pending.append(payload)
            self._pending_bytes += len(prefix) + len(payload)
            if self._pending_bytes >= _FLUSH_AT:
                self.flush()
        self.flush()

    def close(self) -> None:
        if self._transport is not None:
            self._transport.close()

    def connection_lost(self, exc: Exception | None) -> None:
        if self._timer is not None:
            self._timer.cancel()
        self._server._connections.discard(self)
        self._held.clear()
        self._pending.clear()
        if self._topic is not None:
            self._topic.remove(self)
            _log.debug("a subscriber of %s at %s left", self._topic.name, self.peer)
        self._transport = None
