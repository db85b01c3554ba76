"""A bare blocking ROS-TCP client for endpoint tests: sends frames, collects events."""

from __future__ import annotations

import socket
import time
from collections.abc import Callable
from typing import Any

from simbridge.protocol import (
    CommandReceived,
    ErrorMessage,
    Event,
    KeepaliveReceived,
    ProtocolConnection,
    ServiceResponseReceived,
    StatsReply,
    StatsRequest,
    SubscriberCount,
)


class RawClient:
    """Speaks the protocol byte for byte, with no connector logic in between."""

    def __init__(self, port: int, host: str = "127.0.0.1") -> None:
        self.sock = socket.create_connection((host, port), timeout=5)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.proto = ProtocolConnection("client")
        self.events: list[Event] = []

    def send(self, data: bytes) -> None:
        self.sock.sendall(data)

    def poll(self, timeout: float = 0.05) -> None:
        self.sock.settimeout(timeout)
        try:
            data = self.sock.recv(1 << 20)
        except (TimeoutError, BlockingIOError):
            return
        if not data:
            raise ConnectionError("endpoint closed the connection")
        self.events += self.proto.receive_data(data)

    def expect(self, predicate: Callable[[Any], bool], timeout: float = 5.0) -> Any:
        """Wait for (and remove) the first event matching `predicate`."""
        deadline = time.monotonic() + timeout
        while True:
            for i, event in enumerate(self.events):
                if predicate(event):
                    return self.events.pop(i)
            if time.monotonic() > deadline:
                keepalives = sum(isinstance(e, KeepaliveReceived) for e in self.events)
                got = [repr(e)[:200] for e in self.events if not isinstance(e, KeepaliveReceived)]
                raise AssertionError(
                    f"no matching event within {timeout} s; got {got[:10]} and {keepalives} "
                    "keepalives"
                )
            self.poll()

    def call_ros2_service(
        self, request: Callable[[int], bytes], srv_id: int, timeout: float = 120.0
    ) -> ServiceResponseReceived:
        """Send `request(srv_id)` until a ROS 2 server answers it, and return the answer.

        A ROS 2 endpoint fails a call with `__error` when its discovery has not found the
        server within its discovery wait ("no ROS 2 server"), which on a busy machine can
        outlast the server's own start, or when the server answered before it had matched the
        endpoint's new client, so the answer went nowhere (rmw_fastrtps waits only briefly for
        that match; "did not answer"). Such a call is sent again, with the next srv_id."""
        deadline = time.monotonic() + timeout
        while True:
            self.send(request(srv_id))
            event = self.expect(
                lambda e: (
                    isinstance(e, ServiceResponseReceived)
                    or (isinstance(e, CommandReceived) and isinstance(e.command, ErrorMessage))
                ),
                timeout,
            )
            if isinstance(event, ServiceResponseReceived):
                assert event.srv_id == srv_id, (event.srv_id, srv_id)
                return event
            text = event.command.text
            lost = "no ROS 2 server" in text or "did not answer" in text
            if not lost or time.monotonic() > deadline:
                raise AssertionError(f"call {srv_id} failed: {text}")
            srv_id += 1

    def stats(self, timeout: float = 60.0) -> dict[str, Any]:
        """The endpoint's `__stats` reply; also a barrier: every earlier frame was handled."""
        self.send(StatsRequest().encode())
        reply = self.expect(
            lambda e: isinstance(e, CommandReceived) and isinstance(e.command, StatsReply), timeout
        )
        stats: dict[str, Any] = reply.command.stats
        return stats

    def wait_subscribers(self, at_least: int = 1, timeout: float = 20.0) -> int:
        """Wait for a `__subscribers` report (asked with report_subscribers=True) of at least
        `at_least` subscribers; returns that count."""
        event = self.expect(
            lambda e: (
                isinstance(e, CommandReceived)
                and isinstance(e.command, SubscriberCount)
                and e.command.count >= at_least
            ),
            timeout,
        )
        count: int = event.command.count
        return count

    def closed_by_peer(self, timeout: float = 5.0) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                self.poll(0.1)
            except (ConnectionError, OSError):
                return True
        return False

    def close(self) -> None:
        self.sock.close()
