"""The endpoint's TCPROS subscriber connections: messages from ROS publishers, on the loop.

For each publisher the master names, one asyncio connection sends the subscriber
header, checks the publisher's answer (error, md5sum) and then hands every message's
bytes to the topic's callbacks right where they are parsed, with no thread hand-off.
When a consumer says it is blocked (its client stopped reading), the topic stops
reading from its publishers, so TCP pushes back on them instead of messages being
dropped here; reading resumes when the consumer catches up.
"""

from __future__ import annotations

import asyncio
import logging
import socket
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from simbridge.endpoint.backends.base import MessageCallback
from simbridge.endpoint.backends.ros1_raw import RawMessageType
from simbridge.endpoint.backends.ros1_tcpros_pub import connection_ids
from simbridge.protocol.tcpros import TcprosDecoder, TcprosError, encode_header

__all__ = ["Sink", "SubscribedTopic"]

_log = logging.getLogger("simbridge.endpoint.ros1")

CONNECT_TIMEOUT = 10.0
"""Seconds to connect to a publisher and get its header."""

RECHECK = 0.1
"""While reading is paused, how often to ask the consumers again whether they are blocked."""


@dataclass(eq=False, slots=True)
class Sink:
    """One consumer of a topic: its callback and, optionally, whether it is blocked now."""

    callback: MessageCallback
    blocked: Callable[[], bool] | None = None


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
        self._closed = False
        self._tasks: set[asyncio.Task[None]] = set()
        self._recheck: asyncio.TimerHandle | None = None

    @property
    def closed(self) -> bool:
        return self._closed

    def header(self) -> bytes:
        return encode_header(
            {
                "callerid": self.callerid,
                "md5sum": self.info.md5sum,
                "message_definition": self.info.definition,
                "tcp_nodelay": "1",
                "topic": self.name,
                "type": self.info.name,
            }
        )

    def connect(self, pub_uri: str, host: str, port: int) -> None:
        """Connect to the publisher at `host:port` unless connected to `pub_uri` already."""
        if self._closed or pub_uri in self.connections:
            return
        connection = _PublisherConnection(self, pub_uri)
        self.connections[pub_uri] = connection
        task = asyncio.get_running_loop().create_task(connection.open(host, port))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    def deliver(self, queue: deque[bytes]) -> bool:
        """Hand the messages in `queue` to every consumer, in order, until one of them
        says it is blocked: then return True, leaving the rest in `queue`."""
        sinks = self.sinks
        checks = [sink.blocked for sink in sinks if sink.blocked is not None]
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
        for connection in list(self.connections.values()):
            connection.close()
        self.connections.clear()
        for task in list(self._tasks):
            task.cancel()


class _PublisherConnection(asyncio.Protocol):
    """One connection to a ROS publisher of the topic."""

    def __init__(self, topic: SubscribedTopic, pub_uri: str) -> None:
        self.topic = topic
        self.pub_uri = pub_uri
        self.id = next(connection_ids)
        self._decoder = TcprosDecoder(topic.max_message)
        self._transport: asyncio.Transport | None = None
        self._ready = False
        self._reading_paused = False
        self._stash: deque[bytes] = deque()
        """Messages received but not yet delivered (at most one read's worth)."""

    async def open(self, host: str, port: int) -> None:
        loop = asyncio.get_running_loop()
        try:
            await asyncio.wait_for(
                loop.create_connection(lambda: self, host, port), CONNECT_TIMEOUT
            )
        except (OSError, TimeoutError) as exc:
            self._fail(f"cannot connect to {host}:{port}: {exc}")

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        if self.topic.closed:
            transport.close()
            return
        self._transport = transport
        sock = transport.get_extra_info("socket")
        if sock is not None:
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        transport.write(self.topic.header())

    def data_received(self, data: bytes) -> None:
        transport = self._transport
        if transport is None or transport.is_closing():
            return
        try:
            messages = self._decoder.feed(data)
        except TcprosError as exc:
            self._fail(str(exc))
            return
        if not self._ready:
            header = self._decoder.header
            if header is None:
                return
            if not self._check(header):
                return
            self._ready = True
        if messages:
            self._stash.extend(messages)
            if not self._reading_paused:
                self._pump()

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
        self.topic.errors += 1
        if not self.topic.closed:
            _log.warning("cannot receive %s from %s: %s", self.topic.name, self.pub_uri, reason)
        self.close()
        self.topic.forget(self)

    def close(self) -> None:
        if self._transport is not None:
            self._transport.close()

    def connection_lost(self, exc: Exception | None) -> None:
        self._transport = None
        self.topic.forget(self)
