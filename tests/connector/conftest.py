"""Fixtures: a fake endpoint, connectors with fast timings, and a thread-leak check."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable, Iterator

import pytest

from simbridge.connector import Connector, ConnectorOptions
from tests.connector.fake_endpoint import FakeEndpoint

FAST = ConnectorOptions(
    keepalive_interval=0.2,
    dead_timeout=10.0,
    connect_timeout=1.0,
    reconnect_initial=0.1,
    reconnect_max=0.4,
    service_timeout=30.0,
    request_timeout=30.0,
)
"""Quick keepalives and reconnects; generous bounds for what a loaded machine can stretch
(a dead peer, a service answer). Tests of the bounds themselves set short ones of their own."""

QUICK_DEAD = 0.6
"""The dead timeout of tests that wait for a silent peer to be noticed."""

WORKERS = {"simbridge-connector-1", "simbridge-connector-2"}
"""The names of a connector's two dispatcher workers (they read and run callbacks)."""


def _our_threads() -> list[threading.Thread]:
    return [
        t
        for t in threading.enumerate()
        if t.name.startswith(("simbridge-connector", "fake-endpoint"))
    ]


@pytest.fixture(autouse=True)
def _no_leaked_threads() -> Iterator[None]:
    yield
    deadline = time.monotonic() + 5
    while _our_threads() and time.monotonic() < deadline:
        time.sleep(0.01)
    assert not _our_threads(), f"threads left running: {_our_threads()}"


@pytest.fixture
def endpoint() -> Iterator[FakeEndpoint]:
    with FakeEndpoint(
        keepalive=0.2, extensions=["keepalive", "error_srv_id", "stats", "subscribe_queue"]
    ) as ep:
        yield ep


@pytest.fixture
def make_connector() -> Iterator[Callable[..., Connector]]:
    made: list[Connector] = []

    def make(port: int, options: ConnectorOptions = FAST, **kwargs: object) -> Connector:
        connector = Connector(port=port, options=options, **kwargs)  # type: ignore[arg-type]
        made.append(connector)
        return connector

    yield make
    for connector in made:
        connector.close()


@pytest.fixture
def pair() -> Iterator[tuple[socket.socket, socket.socket]]:
    """A loopback TCP connection (TCP takes part of a send when its buffer is nearly full)."""
    with socket.create_server(("127.0.0.1", 0)) as server:
        a = socket.create_connection(server.getsockname())
        b, _ = server.accept()
    # blocking, as open_link leaves its socket, whatever default timeout an earlier test's
    # library set (rospy sets 60 s on import; a send then waits instead of falling short)
    a.settimeout(None)
    b.settimeout(None)
    yield a, b
    a.close()
    b.close()


def read_exactly(sock: socket.socket, size: int, timeout: float = 5.0) -> bytes:
    """`size` bytes from `sock` (fewer only if it closes); `timeout` bounds each read."""
    sock.settimeout(timeout)
    data = bytearray()
    while len(data) < size:
        chunk = sock.recv(size - len(data))
        if not chunk:
            break
        data += chunk
    return bytes(data)
