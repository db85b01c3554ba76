"""A client that publishes numbered Twists and leaves at once: the endpoint must deliver
everything it accepted (tests of every backend, benchmarks/bench_drain.py)."""

from __future__ import annotations

import socket
import struct
import time
from dataclasses import dataclass, field
from typing import Any

from simbridge.protocol import (
    CommandReceived,
    Event,
    ProtocolConnection,
    Publish,
    StatsReply,
    StatsRequest,
    SubscriberCount,
)
from simbridge.protocol.framing import encode_frame

__all__ = ["CDR_HEADER", "Sent", "publish_and_close", "twist", "twist_number"]

CDR_HEADER = b"\x00\x01\x00\x00"
"""The encapsulation header in front of a ROS 2 (CDR, little-endian) message."""
_SIX = struct.Struct("<6d")


def twist(k: int, *, cdr: bool) -> bytes:
    """geometry_msgs/Twist number `k` (linear.x == k): CDR for ROS 2, else ROS 1's bytes."""
    body = _SIX.pack(k, 0, 0, 0, 0, 0)
    return CDR_HEADER + body if cdr else body


def twist_number(payload: bytes, *, cdr: bool) -> int:
    """The `k` of a payload made by `twist`."""
    return int(_SIX.unpack_from(payload, 4 if cdr else 0)[0])


@dataclass
class Sent:
    """When sending began and the socket was shut down (time.monotonic()), and the
    endpoint's `__stats` after the last message (when asked for)."""

    began: float
    closed: float
    stats: dict[str, Any] = field(default_factory=dict)


def publish_and_close(
    port: int,
    topic: str,
    count: int,
    queue_size: int,
    *,
    cdr: bool,
    stats: bool = False,
    timeout: float = 60.0,
) -> Sent:
    """Register `topic` (geometry_msgs/Twist, `queue_size`), wait until it has a
    subscriber, send Twists 0..count-1 in one go (then `__stats` when `stats`: the endpoint
    answers once it has handled every message before it) and shut the socket down at once.
    The socket is closed once the endpoint has closed its side, after reading to the end:
    a socket closed with unread data (a keepalive) is reset, and the kernel drops what the
    client had not sent yet: the client's loss, not the endpoint's."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=timeout)
    proto = ProtocolConnection("client")
    events: list[Event] = []
    try:
        register = Publish(topic, "geometry_msgs/Twist", queue_size, report_subscribers=True)
        sock.sendall(register.encode())
        _read_until(sock, proto, events, _matched, f"a subscriber of {topic}")
        frames = b"".join(encode_frame(topic, twist(k, cdr=cdr)) for k in range(count))
        sock.settimeout(None)  # sending may wait for the endpoint's push-back
        began = time.monotonic()
        sock.sendall(frames)
        reply: dict[str, Any] = {}
        if stats:
            sock.settimeout(timeout)
            sock.sendall(StatsRequest().encode())
            event = _read_until(sock, proto, events, _stats, "the __stats reply")
            assert isinstance(event, CommandReceived)
            assert isinstance(event.command, StatsReply)
            reply = event.command.stats
        sock.shutdown(socket.SHUT_WR)
        closed = time.monotonic()
        sock.settimeout(timeout)
        while sock.recv(65536):
            pass
    finally:
        sock.close()
    return Sent(began, closed, reply)


def _matched(event: Event) -> bool:
    """A subscriber is there (or the backend cannot tell: -1)."""
    command = event.command if isinstance(event, CommandReceived) else None
    return isinstance(command, SubscriberCount) and command.count != 0


def _stats(event: Event) -> bool:
    return isinstance(event, CommandReceived) and isinstance(event.command, StatsReply)


def _read_until(
    sock: socket.socket,
    proto: ProtocolConnection,
    events: list[Event],
    wanted: Any,
    what: str,
) -> Event:
    """The first event `wanted` says yes to, read within the socket's timeout."""
    timeout = sock.gettimeout() or 60.0
    deadline = time.monotonic() + timeout
    while True:
        for i, event in enumerate(events):
            if wanted(event):
                return events.pop(i)
        if time.monotonic() > deadline:
            raise AssertionError(f"no {what} within {timeout} s")
        sock.settimeout(max(0.01, deadline - time.monotonic()))
        data = sock.recv(65536)
        if not data:
            raise AssertionError(f"the endpoint closed the connection before {what}")
        events.extend(proto.receive_data(data))
