"""SocketWriter: in-order writes from the caller's buffers to a socket whose reader lags,
without copying what the kernel does not take at once, and a clean stop on errors."""

from __future__ import annotations

import asyncio
import socket
import threading
import tracemalloc
from collections.abc import Iterator
from typing import Any

import pytest

from simbridge.endpoint.speed.writev import SocketWriter, write_chunks

MB = 1 << 20


@pytest.fixture
def pair() -> Iterator[tuple[socket.socket, socket.socket]]:
    """A connected loopback TCP pair with small kernel buffers (writer, reader)."""
    with socket.create_server(("127.0.0.1", 0)) as server:
        writer = socket.create_connection(server.getsockname())
        reader, _ = server.accept()
    writer.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 64 * 1024)
    reader.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 64 * 1024)
    writer.setblocking(False)
    reader.setblocking(False)
    try:
        yield writer, reader
    finally:
        writer.close()
        reader.close()


async def _read(sock: socket.socket, size: int) -> bytes:
    loop = asyncio.get_running_loop()
    got = bytearray()
    while len(got) < size:
        got += await loop.sock_recv(sock, min(size - len(got), MB))
    return bytes(got)


def test_chunks_arrive_whole_and_in_order_to_a_lagging_reader(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    out, into = pair
    errors: list[OSError] = []
    chunks: list[bytes | bytearray] = []
    for i in range(40):  # small headers between payloads of 1 B .. 1 MB, bytes and bytearrays
        chunks.append(i.to_bytes(4, "little"))
        payload = bytes([i]) * (1 + (i * 26_041) % MB)
        chunks.append(payload if i % 2 else bytearray(payload))
    expected = b"".join(chunks)

    async def scenario() -> tuple[bytes, int, int]:
        drained = 0

        def on_drained() -> None:
            nonlocal drained
            drained += 1

        writer = SocketWriter(asyncio.get_running_loop(), out.fileno(), on_drained, errors.append)
        for start in range(0, len(chunks), 8):
            writer.write(chunks[start : start + 8])
        queued = writer.queued
        assert 0 < queued < len(expected)  # the kernel took some; the rest waits
        got = await _read(into, len(expected))
        assert writer.queued == 0
        return got, drained, queued

    got, drained, _ = asyncio.run(scenario())
    assert not errors
    assert got == expected
    assert drained == 1  # once, when the queue emptied


def test_what_the_kernel_does_not_take_is_not_copied(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    """An 8 MB payload against a full socket waits as (a view of) itself: the writer
    allocates nothing near its size, where a transport's buffer would copy it."""
    out, into = pair
    errors: list[OSError] = []
    payload = bytes(range(256)) * (8 * MB // 256)

    async def scenario() -> tuple[int, bytes]:
        loop = asyncio.get_running_loop()
        writer = SocketWriter(loop, out.fileno(), lambda: None, errors.append)
        tracemalloc.start()
        try:
            writer.write([b"head", payload])
            writer.write([b"tail"])
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        assert writer.queued > 4 * MB
        return peak, await _read(into, len(payload) + 8)

    peak, got = asyncio.run(scenario())
    assert not errors
    assert peak < 64 * 1024
    assert got == b"head" + payload + b"tail"


def test_a_failed_write_reports_once_and_stops(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    out, into = pair
    errors: list[OSError] = []
    drained = threading.Event()

    async def scenario() -> SocketWriter:
        writer = SocketWriter(asyncio.get_running_loop(), out.fileno(), drained.set, errors.append)
        writer.write([bytes(4 * MB)])  # most of it waits for the reader
        into.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, b"\x01\x00\x00\x00\x00\x00\x00\x00")
        into.close()  # reset: the next write fails
        for _ in range(200):
            if errors:
                break
            await asyncio.sleep(0.01)
        writer.write([b"after the error"])
        return writer

    writer = asyncio.run(scenario())
    assert len(errors) == 1
    assert isinstance(errors[0], ConnectionError)
    assert writer.closed
    assert writer.queued == 0
    assert not drained.is_set()


def test_write_chunks_gives_the_transport_its_own_copy_of_a_lent_view(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    """What the kernel does not take goes to the transport; a transport that keeps what it
    is given without copying (asyncio's since Python 3.12) must not see a lent buffer
    change when its owner reuses it after the call."""

    class KeepingTransport:
        def __init__(self) -> None:
            self.kept: list[Any] = []

        def get_write_buffer_size(self) -> int:
            return sum(len(chunk) for chunk in self.kept)

        def write(self, data: Any) -> None:
            self.kept.append(data)

    out, into = pair
    lent = bytearray(b"a" * 4 * MB)
    transport: Any = KeepingTransport()
    with memoryview(lent) as view:
        write_chunks(transport, out.fileno(), [b"head", view])
    lent[:] = b"b" * len(lent)  # the owner takes its next message into the same memory
    assert transport.kept  # the kernel did not take it all
    received = bytearray()
    while True:
        try:
            received += into.recv(MB)
        except BlockingIOError:
            break
    assert received + b"".join(bytes(chunk) for chunk in transport.kept) == b"head" + b"a" * 4 * MB
