"""The endpoint's own TCPROS server: ROS subscribers of its topics connect here.

Runs on the endpoint's event loop, so a publish is a few appends and one write per
connection per read of the client's frames (everything one read brings in goes out in
one `writev`, right at the end of that read: see `endpoint.speed.deferred`), with no thread
hand-off. The sockets are the server's own, not asyncio transports: what the kernel
does not take at once waits as the messages' own bytes (`endpoint.speed.writev.SocketWriter`),
where a transport would copy the rest of each camera image into its buffer and copy it
again as that buffer drains. A connection with more than `WRITE_HIGH_WATER` bytes
waiting holds further messages in a queue bounded by the registration's `queue_size`
(and a byte cap); past that the oldest are dropped and counted, as rospy's publisher
queue does. A topic with queue_size 0 may not drop: while one of its connections is
behind, its publishers' clients are not read (`endpoint.session.pushback`).
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import socket
import struct
from collections import deque
from collections.abc import Callable

from simbridge.endpoint.backends.ros1.raw import RawMessageType
from simbridge.endpoint.speed.deferred import DeferredWrites, deferred_writes
from simbridge.endpoint.speed.splice import MAX_BACKLOG, SINK_WAIT, unsent
from simbridge.endpoint.speed.writev import SocketWriter
from simbridge.protocol.tcpros import TcprosDecoder, TcprosError, encode_header

__all__ = ["PublishedTopic", "TopicServer", "connection_ids"]

_log = logging.getLogger("simbridge.endpoint.ros1")

HEADER_TIMEOUT = 10.0
"""Seconds a new connection has to send its header."""

MAX_HELD_BYTES = 512 << 20
"""Bytes one connection may hold while its subscriber is not reading (queue_size 0 is
unbounded in count, as in rospy, but not in bytes)."""

WRITE_HIGH_WATER = 1 << 20
"""Bytes the kernel has not taken yet, past which a connection holds further messages
(subject to queue_size) until all of them are taken."""

_ACCEPT_BACKLOG = 128
_ACCEPTS_PER_WAKE = 32
"""Connections accepted per readiness of the listening socket (then the loop moves on)."""


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
        self.latched: tuple[bytes, bytes | bytearray] | None = None
        """The length prefix and payload of the last message, when latching."""
        self.dropped = 0
        self.watchers: list[Callable[[int], None]] = []
        self.behind: set[_SubscriberConnection] = set()
        """Connections holding messages for a subscriber that is not keeping up, while the
        topic may not drop (queue_size 0): the publishing clients are not read meanwhile."""
        self.backlog_watchers: list[tuple[Callable[[], None], Callable[[], None]]] = []
        """(behind, caught_up) callbacks of the publishers (`watch_backlog`)."""

    def publish(self, payload: bytes | bytearray) -> None:
        """Send one serialized message to every connected subscriber (a bytearray is
        sent as it is: nobody may write to it afterwards)."""
        prefix = _U32.pack(len(payload))
        if self.latch:
            self.latched = (prefix, payload)
        for connection in self.connections:
            connection.send(prefix, payload)

    def splice_sink(self) -> _SubscriberConnection | None:
        """The connection a large message may be spliced to (`endpoint.speed.splice`): the
        topic's only subscriber, keeping up, on a topic that does not latch (a latched
        message is kept, so it must be in memory)."""
        if self.latch or len(self.connections) != 1:
            return None
        connection = self.connections[0]
        return connection if connection.can_splice() and connection.keeping_up() else None

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
        self.caught_up(connection)
        if connection in self.connections:
            self.connections.remove(connection)
            self._changed()

    def fell_behind(self, connection: _SubscriberConnection) -> None:
        """`connection` holds messages its subscriber has not taken: with queue_size 0
        (nothing may be dropped) the publishers' clients are pushed back on."""
        if self.queue_size != 0 or connection in self.behind:
            return
        self.behind.add(connection)
        if len(self.behind) == 1:
            self.server.pushbacks += 1
            for behind, _ in list(self.backlog_watchers):
                behind()

    def caught_up(self, connection: _SubscriberConnection) -> None:
        """`connection`'s subscriber took everything (or left)."""
        if connection not in self.behind:
            return
        self.behind.discard(connection)
        if not self.behind:
            for _, caught_up in list(self.backlog_watchers):
                caught_up()

    def undelivered(self) -> int:
        """Messages its connections hold that the kernel has not taken yet, at most (0:
        every subscriber's socket has all; a partly sent one counts whole)."""
        return sum(connection.undelivered() for connection in self.connections)

    def close(self) -> None:
        """Close every connection (the topic is no longer published)."""
        for connection in list(self.connections):
            connection.close()
            self.caught_up(connection)
        self.connections.clear()
        self.watchers.clear()
        self.backlog_watchers.clear()


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
        self.pushbacks = 0
        """Times a topic that may not drop had a subscriber fall behind (see `fell_behind`)."""
        self.spliced = 0
        """Large messages moved to a subscriber by splice (`endpoint.speed.splice`)."""
        self._listener: socket.socket | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._writes: DeferredWrites | None = None
        self._dirty: list[_SubscriberConnection] = []
        self._connections: set[_SubscriberConnection] = set()
        self.port = 0

    async def start(self, bind_host: str) -> None:
        """Listen on `bind_host` (an address) at a free port."""
        loop = asyncio.get_running_loop()
        family, kind, proto, _, address = (
            await loop.getaddrinfo(bind_host, 0, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
        )[0]
        listener = socket.socket(family, kind, proto)
        try:
            listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            listener.bind(address)
            listener.listen(_ACCEPT_BACKLOG)
            listener.setblocking(False)
        except BaseException:
            listener.close()
            raise
        self._loop = loop
        self._writes = deferred_writes(loop)
        self._listener = listener
        self.port = listener.getsockname()[1]
        loop.add_reader(listener.fileno(), self._accept)

    def _accept(self) -> None:
        listener, loop = self._listener, self._loop
        if listener is None or loop is None:
            return
        for _ in range(_ACCEPTS_PER_WAKE):
            try:
                sock, _ = listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:  # out of file descriptors: those waiting stay queued
                _log.warning("cannot accept a TCPROS connection: %s", exc)
                return
            self._connections.add(_SubscriberConnection(self, sock, loop))

    def forget(self, connection: _SubscriberConnection) -> None:
        """`connection` has closed."""
        self._connections.discard(connection)

    def close(self) -> None:
        """Stop listening and close every connection."""
        listener, self._listener = self._listener, None
        if listener is not None and self._loop is not None:
            self._loop.remove_reader(listener.fileno())
            listener.close()
        for topic in list(self.topics.values()):
            topic.close()
        self.topics.clear()
        for connection in list(self._connections):
            connection.abort()

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


class _SubscriberConnection:
    """One ROS subscriber connected to the server: header exchange, then outgoing frames."""

    def __init__(
        self, server: TopicServer, sock: socket.socket, loop: asyncio.AbstractEventLoop
    ) -> None:
        self._server = server
        self._sock = sock
        self._fd = sock.fileno()
        self._loop = loop
        self._decoder = TcprosDecoder(server.max_message)
        self._topic: PublishedTopic | None = None
        self._pending: list[bytes | bytearray] = []
        self._pending_bytes = 0
        self._held: deque[tuple[bytes, bytes | bytearray]] = deque()
        self._held_bytes = 0
        self._paused = False
        self._closing = False
        self._closed = False
        self._splice: Callable[[], None] | None = None
        """While a relay owns the socket: what to call if the connection goes away."""
        self.peer = "?"
        self.callerid = "?"
        """The subscriber node, from its header."""
        self.id = next(connection_ids)
        sock.setblocking(False)
        self._writer = SocketWriter(loop, self._fd, self._drained, self._write_failed)
        try:
            peer = sock.getpeername()
        except OSError:
            peer = None
        self.peer = f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) else str(peer)
        loop.add_reader(self._fd, self._readable)
        self._timer: asyncio.TimerHandle | None = loop.call_later(
            HEADER_TIMEOUT, self._header_timeout
        )

    def _header_timeout(self) -> None:
        if self._topic is None:
            self._refuse(f"no connection header within {HEADER_TIMEOUT} s")

    def _readable(self) -> None:
        try:
            data = self._sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            _log.debug("a subscriber connection from %s failed: %s", self.peer, exc)
            self.abort()
            return
        if not data:  # the subscriber left
            self.abort()
            return
        if self._topic is not None or self._closing:
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
            self._timer = None
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
        if header.get("tcp_nodelay", "0").strip() == "1":
            self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._writer.write([topic.header(self._server.callerid)])
        self.callerid = header["callerid"]
        self._topic = topic
        topic.add(self)
        _log.debug("%s subscribed to %s from %s", header["callerid"], name, self.peer)

    def _refuse(self, reason: str) -> None:
        self._server.refused += 1
        _log.warning("refused a TCPROS connection from %s: %s", self.peer, reason)
        if not self._closing and not self._closed:
            self._writer.write([encode_header({"error": reason})])
            self.close()

    def can_splice(self) -> bool:
        """Whether a relay may take this connection now: subscribed, free, and with
        nothing waiting for the subscriber (a relay never waits for it)."""
        return (
            self._topic is not None
            and self._splice is None
            and not (self._paused or self._closing or self._held or self._writer.queued)
        )

    def keeping_up(self) -> bool:
        """Little in the socket the subscriber has not taken: one behind reads copies
        faster (`endpoint.speed.splice.MAX_BACKLOG`); asked once per large message."""
        return unsent(self._fd) < MAX_BACKLOG

    @property
    def splice_wait(self) -> float:
        """How long a relay waits for room in this socket (`endpoint.speed.splice.SpliceSink`)."""
        topic = self._topic
        return SINK_WAIT if topic is not None and topic.queue_size == 0 else 0.0

    def splice_start(self, lost: Callable[[], None]) -> int | None:
        """The socket for a relay once what this read queued is sent, else None; messages
        sent meanwhile are held (`endpoint.speed.splice.SpliceSink`)."""
        if not self.can_splice():
            return None
        self.flush()
        if self._writer.queued or self._paused or self._closing:
            return None
        self._splice = lost
        return self._fd

    def splice_end(self, rest: list[bytes | memoryview] | None, *, moved: bool = True) -> None:
        """The relay is done: queue the part of its message it did not move, then what was
        held; None: it cut a message short, so close."""
        self._splice = None
        if rest is None:
            self.abort()
            return
        self._server.spliced += moved
        if rest and not self._closing:
            self._writer.write(rest)
            if self._writer.queued > WRITE_HIGH_WATER:  # as `flush` does
                self._paused = True
                if self._topic is not None:
                    self._topic.fell_behind(self)
                return
        self._drained()

    def send(self, prefix: bytes, payload: bytes | bytearray) -> None:
        """Queue one message (its length prefix and bytes); it leaves once the read that
        published it is done, or is held while the subscriber is not reading."""
        if self._paused or self._splice is not None:
            self._hold(prefix, payload)
            return
        if not self._pending:
            self._server.schedule(self)
        self._pending.append(prefix)
        self._pending.append(payload)
        self._pending_bytes += len(prefix) + len(payload)
        if self._pending_bytes >= _FLUSH_AT:
            self.flush()  # past WRITE_HIGH_WATER the next ones are held

    def _hold(self, prefix: bytes, payload: bytes | bytearray) -> None:
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
        """Write what was queued: one scatter-gather syscall straight from the messages'
        bytes while nothing waits before them; the rest waits as it is (no copy)."""
        pending, self._pending = self._pending, []
        self._pending_bytes = 0
        if not pending or self._closing or self._closed:
            return
        writer = self._writer
        writer.write(pending)
        if writer.queued > WRITE_HIGH_WATER:
            self._paused = True
            if self._topic is not None:
                self._topic.fell_behind(self)

    def _drained(self) -> None:
        """The kernel took everything written: send what was held meanwhile."""
        if self._closing:
            self.abort()
            return
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
        if not self._paused:
            self.flush()
        if not self._paused and self._topic is not None:
            self._topic.caught_up(self)

    def undelivered(self) -> int:
        """Messages held, queued or partly written, at most (each is a length prefix and a
        payload: two chunks)."""
        if self._closed:
            return 0
        return len(self._held) + (len(self._pending) + self._writer.chunks + 1) // 2

    def _write_failed(self, exc: OSError) -> None:
        _log.debug("a subscriber connection to %s failed: %s", self.peer, exc)
        self.abort()

    def close(self) -> None:
        """Close once what was written has been sent (at once if nothing waits)."""
        if self._closed or self._closing:
            return
        self._closing = True
        self._held.clear()
        self._held_bytes = 0
        self._pending.clear()
        if not self._writer.queued:
            self.abort()

    def abort(self) -> None:
        """Close now, dropping anything not yet sent."""
        if self._closed:
            return
        self._closed = self._closing = True
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        splice, self._splice = self._splice, None
        if splice is not None:
            splice()  # the relay lets go of the socket before it closes
        self._writer.close()
        self._loop.remove_reader(self._fd)
        self._sock.close()
        self._server.forget(self)
        self._held.clear()
        self._pending.clear()
        if self._topic is not None:
            self._topic.remove(self)
            _log.debug("a subscriber of %s at %s left", self._topic.name, self.peer)
