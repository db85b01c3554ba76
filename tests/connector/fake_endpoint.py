"""A small threaded ROS-TCP endpoint for connector tests, built on ProtocolConnection.

It records every event each client sends, answers service calls with a handler,
replies to `__topic_list` / `__stats`, sends keepalives (or goes silent), and can be
killed and restarted on the same port.
"""

from __future__ import annotations

import contextlib
import socket
import threading
from collections.abc import Callable
from typing import Any

from simbridge.protocol import (
    KEEPALIVE,
    CommandReceived,
    ErrorMessage,
    Event,
    Handshake,
    ProtocolConnection,
    ServiceRequestReceived,
    StatsReply,
    StatsRequest,
    TopicListReply,
    TopicListRequest,
)
from tests.waiting import wait_for

ServiceAnswer = Callable[[str, bytes], bytes | None]
"""(service, request) -> response bytes, or None to answer with `__error` + srv_id."""


class FakeClientConn:
    """One accepted client: its socket, protocol state and received events."""

    def __init__(self, sock: socket.socket, endpoint: FakeEndpoint) -> None:
        self.sock = sock
        self.endpoint = endpoint
        self.proto = ProtocolConnection("endpoint")
        self.events: list[Event] = []
        self.send_lock = threading.Lock()
        self.closed = False
        self.thread = threading.Thread(target=self._read, daemon=True, name="fake-endpoint-conn")

    def send(self, data: bytes) -> None:
        with self.send_lock:
            self.sock.sendall(data)

    def close(self) -> None:
        self.closed = True
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)
        self.sock.close()

    def _read(self) -> None:
        while not self.closed:
            try:
                data = self.sock.recv(1 << 20)
            except OSError:
                break
            if not data:
                break
            events = self.proto.receive_data(data)
            with self.endpoint.lock:
                self.events.extend(events)
                self.endpoint.bytes_received += len(data)
            for event in events:
                try:
                    self._answer(event)
                except OSError:
                    return
        self.closed = True
        with contextlib.suppress(OSError):  # answer the client's FIN like a server would
            self.sock.shutdown(socket.SHUT_RDWR)

    def _answer(self, event: Event) -> None:
        ep = self.endpoint
        if not ep.answer:
            return
        if isinstance(event, ServiceRequestReceived) and ep.service_answer is not None:
            response = ep.service_answer(event.service, event.payload)
            if response is None:
                self.send(ErrorMessage(f"{event.service} failed", event.srv_id).encode())
            else:
                self.send(
                    ProtocolConnection.service_response(event.srv_id, event.service, response)
                )
        elif isinstance(event, CommandReceived):
            cmd = event.command
            if isinstance(cmd, TopicListRequest):
                topics = tuple(ep.topics)
                self.send(TopicListReply(topics, tuple(ep.topics[t] for t in topics)).encode())
            elif isinstance(cmd, StatsRequest):
                self.send(StatsReply({"frames_in": len(self.events)}).encode())


class FakeEndpoint:
    """Listens on 127.0.0.1 (a free port unless given); one thread per client."""

    def __init__(
        self,
        port: int = 0,
        *,
        keepalive: float | None = 1.0,
        service_answer: ServiceAnswer | None = None,
        protocol: str = "ROS1",
        extensions: list[str] | None = None,
        send_handshake: bool = True,
    ) -> None:
        self.keepalive = keepalive
        """Seconds between keepalives, announced in the handshake; None acts like the
        original endpoint (no keepalives, nothing announced)."""
        self.service_answer = service_answer
        self.protocol = protocol
        self.extensions = extensions
        """Announced in the handshake when not None (the simbridge endpoint does)."""
        self.send_handshake = send_handshake
        self.topics: dict[str, str] = {}
        self.silent = False
        """When True nothing more is sent (simulates a hung endpoint)."""
        self.answer = True
        """When False requests (services, topic list, stats) get no reply."""
        self.lock = threading.Lock()
        self.conns: list[FakeClientConn] = []
        self.bytes_received = 0
        self._stop = threading.Event()
        self._listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._listener.bind(("127.0.0.1", port))
        self._listener.listen(64)
        self.port: int = self._listener.getsockname()[1]
        self._threads = [
            threading.Thread(target=self._accept, daemon=True, name="fake-endpoint-accept"),
            threading.Thread(target=self._keepalives, daemon=True, name="fake-endpoint-ka"),
        ]
        for thread in self._threads:
            thread.start()

    def __enter__(self) -> FakeEndpoint:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def handshake(self) -> bytes:
        meta: dict[str, Any] = {"protocol": self.protocol}
        if self.keepalive is not None:
            meta["keepalive"] = self.keepalive
        if self.extensions is not None:
            meta["extensions"] = self.extensions
        return Handshake("v0.7.0", meta).encode()

    def _accept(self) -> None:
        while not self._stop.is_set():
            try:
                sock, _ = self._listener.accept()
            except OSError:
                return
            conn = FakeClientConn(sock, self)
            with self.lock:
                self.conns.append(conn)
            if self.send_handshake:
                try:
                    conn.send(self.handshake())
                except OSError:
                    continue
            conn.thread.start()

    def _keepalives(self) -> None:
        while not self._stop.wait(self.keepalive or 0.2):
            if self.keepalive is None or self.silent:
                continue
            for conn in self.live_conns():
                with contextlib.suppress(OSError):
                    conn.send(KEEPALIVE)

    def live_conns(self) -> list[FakeClientConn]:
        with self.lock:
            return [c for c in self.conns if not c.closed]

    def send_all(self, data: bytes) -> None:
        for conn in self.live_conns():
            conn.send(data)

    def events(self, conn_index: int = -1) -> list[Event]:
        with self.lock:
            return list(self.conns[conn_index].events) if self.conns else []

    def wait_for(self, predicate: Callable[[], bool], timeout: float = 60.0) -> bool:
        return wait_for(predicate, timeout)

    def wait_conns(self, count: int, timeout: float = 60.0) -> bool:
        return self.wait_for(lambda: len(self.conns) >= count, timeout)

    def stop(self) -> None:
        """Close the listener and every client connection; join the threads."""
        self._stop.set()
        with contextlib.suppress(OSError):
            self._listener.shutdown(socket.SHUT_RDWR)
        self._listener.close()
        with self.lock:
            conns = list(self.conns)
        for conn in conns:
            conn.close()
        for thread in self._threads:
            thread.join(timeout=5)
        for conn in conns:
            if conn.thread.is_alive():
                conn.thread.join(timeout=5)
