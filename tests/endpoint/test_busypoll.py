"""BusyPollSelector: spins only after work, never past asyncio's timeout, and an asyncio
loop built on it serves as the default one does."""

from __future__ import annotations

import asyncio
import selectors
import socket
import threading
import time
from collections.abc import Iterator

import pytest

from simbridge.endpoint.busypoll import MAX_BUSY_POLL_US, BusyPollSelector
from simbridge.errors import EndpointError, SimbridgeError


@pytest.fixture
def pair() -> Iterator[tuple[socket.socket, socket.socket]]:
    a, b = socket.socketpair()
    yield a, b
    a.close()
    b.close()


@pytest.fixture
def hot(
    pair: tuple[socket.socket, socket.socket],
) -> Iterator[tuple[BusyPollSelector, socket.socket]]:
    """A selector (0.1 s spin) watching `pair`'s reader, whose last select returned an
    event, so its next one may spin; and the writer."""
    reader, writer = pair
    with BusyPollSelector(MAX_BUSY_POLL_US) as selector:
        selector.register(reader, selectors.EVENT_READ)
        writer.send(b"x")
        assert selector.select(1.0)
        reader.recv(16)
        yield selector, writer


@pytest.mark.parametrize("spin_us", [-1, MAX_BUSY_POLL_US + 1, float("nan")])
def test_out_of_range_spin_is_refused_naming_it(spin_us: float) -> None:
    with pytest.raises(EndpointError, match=f"busy-poll time {spin_us!r}.*expected 0 to 100000"):
        BusyPollSelector(spin_us)
    assert issubclass(EndpointError, SimbridgeError)


def test_an_idle_loop_blocks_without_spinning(pair: tuple[socket.socket, socket.socket]) -> None:
    reader, _ = pair
    with BusyPollSelector(50_000) as selector:
        selector.register(reader, selectors.EVENT_READ)
        started = time.perf_counter()
        assert selector.select(0.05) == []
        assert time.perf_counter() - started >= 0.04
        assert selector.polls == 0
        assert selector.spin_seconds == 0


def test_after_work_an_event_within_the_spin_is_found_by_polling(
    hot: tuple[BusyPollSelector, socket.socket],
) -> None:
    selector, writer = hot
    late = threading.Timer(0.02, writer.send, (b"y",))
    late.start()
    ready = selector.select(None)
    late.join()
    assert len(ready) == 1
    assert selector.hits == 1
    assert selector.polls > 1
    assert 0.015 <= selector.spin_seconds < 1.0


def test_a_spin_ends_at_asyncio_timeout_and_the_next_wait_sleeps(
    hot: tuple[BusyPollSelector, socket.socket],
) -> None:
    selector, _ = hot
    started = time.perf_counter()
    assert selector.select(0.01) == []
    assert time.perf_counter() - started < 0.09  # well short of the 0.1 s spin
    assert selector.hits == 0
    polls = selector.polls
    assert polls > 0
    assert selector.select(0.01) == []  # nothing came: no more spinning
    assert selector.polls == polls


def test_a_zero_timeout_look_neither_spins_nor_forgets_work(
    hot: tuple[BusyPollSelector, socket.socket],
) -> None:
    selector, _ = hot
    assert selector.select(0) == []  # asyncio with callbacks ready
    assert selector.polls == 0
    assert selector.select(0.005) == []  # the wait after them still spins
    assert selector.polls > 0


def test_an_asyncio_loop_on_it_echoes() -> None:
    selector = BusyPollSelector(2_000)

    async def main() -> list[bytes]:
        async def echo(r: asyncio.StreamReader, w: asyncio.StreamWriter) -> None:
            while data := await r.read(64):
                w.write(data)
            w.close()

        server = await asyncio.start_server(echo, "127.0.0.1", 0)
        port = server.sockets[0].getsockname()[1]
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        got = []
        for i in range(50):
            writer.write(b"%d;" % i)
            got.append(await reader.readuntil(b";"))
        writer.close()
        server.close()
        await server.wait_closed()
        return got

    with asyncio.Runner(loop_factory=lambda: asyncio.SelectorEventLoop(selector)) as runner:
        assert runner.run(main()) == [b"%d;" % i for i in range(50)]
    assert selector.hits > 0
