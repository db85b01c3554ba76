"""BusyPollSelector: learns to spin for answers on another socket, not for streams; an asyncio
loop on it serves as the default one does. The learning itself (`SpinPolicy`) is tested as
arithmetic in test_spin_policy.py; here every event is on its socket before the selector
looks, so what it does is decided by order, not by how fast the machine is."""

from __future__ import annotations

import asyncio
import selectors
import socket
from collections.abc import Iterator

import pytest

from simbridge.endpoint.speed.busypoll import MAX_BUSY_POLL_US, BusyPollSelector
from simbridge.endpoint.speed.spin_policy import SHORTEST
from simbridge.errors import EndpointError


class Wires:
    """Two socket pairs (as a sim client and a ROS node) watched by one selector."""

    def __init__(self, selector: BusyPollSelector) -> None:
        self.selector = selector
        self.pairs = [socket.socketpair(), socket.socketpair()]
        for reader, _ in self.pairs:
            selector.register(reader, selectors.EVENT_READ)

    def event(self, which: int, timeout: float | None = 60.0) -> None:
        """A byte waiting on pair `which` before the selector looks: it must return that."""
        self.pairs[which][1].send(b"x")
        ready = self.selector.select(timeout)
        assert [key.fileobj for key, _ in ready] == [self.pairs[which][0]]
        self.pairs[which][0].recv(16)

    def window(self, which: int) -> float:
        return self.selector.window(self.pairs[which][0])

    def close(self) -> None:
        for reader, writer in self.pairs:
            reader.close()
            writer.close()


@pytest.fixture
def wires() -> Iterator[Wires]:
    # the longest limit: a wait for a byte already there stays far below it on any machine
    with BusyPollSelector(MAX_BUSY_POLL_US) as selector:
        w = Wires(selector)
        yield w
        w.close()


def learned(wires: Wires) -> Wires:
    """Work on pair 0, answered on pair 1, answered on pair 0: both have learned a spin."""
    for which in (0, 1, 0):
        wires.event(which)
    assert wires.window(0) > 0
    assert wires.window(1) > 0
    assert wires.selector.polls == 0  # learning is from blocking waits alone
    return wires


@pytest.mark.parametrize("limit_us", [-1, MAX_BUSY_POLL_US + 1, float("nan")])
def test_out_of_range_limit_is_refused_naming_it(limit_us: float) -> None:
    with pytest.raises(EndpointError, match=f"busy-poll time {limit_us!r}.*expected 0 to 100000"):
        BusyPollSelector(limit_us)


@pytest.mark.parametrize("duty", [0, -0.5, 1.5])
def test_out_of_range_duty_is_refused_naming_it(duty: float) -> None:
    with pytest.raises(EndpointError, match=f"busy-poll duty {duty!r}.*expected"):
        BusyPollSelector(100, duty)


def test_an_idle_loop_blocks_without_spinning(wires: Wires) -> None:
    assert wires.selector.select(0.05) == []
    assert (wires.selector.polls, wires.selector.spin_seconds) == (0, 0)


def test_a_learned_spin_catches_the_next_answer(wires: Wires) -> None:
    selector = learned(wires).selector
    wires.event(1)  # the answer to pair 0's work: found by polling, not by sleeping
    assert (selector.hits, selector.misses) == (1, 0)
    assert selector.polls >= 1
    assert selector.spin_seconds > 0


def test_a_stream_on_one_socket_never_spins(wires: Wires) -> None:
    for _ in range(6):
        wires.event(0)
    assert wires.window(0) == 0
    assert wires.selector.polls == 0


def test_a_spin_that_finds_the_same_socket_again_shrinks(wires: Wires) -> None:
    selector = learned(wires).selector
    before = wires.window(0)
    wires.event(0)  # pair 0 again: a stream, not an answer
    assert selector.hits == 1
    assert wires.window(0) == (before / 2 if before / 2 >= SHORTEST else 0.0)


def test_a_spin_that_finds_nothing_is_a_miss_and_the_next_wait_sleeps(wires: Wires) -> None:
    selector = learned(wires).selector
    assert selector.select(0.2) == []  # nothing comes: spin, then sleep
    assert (selector.hits, selector.misses) == (0, 1)
    polls = selector.polls
    assert polls > 0
    assert selector.select(0.01) == []  # the loop is idle now: no more spinning
    assert selector.polls == polls


def test_a_zero_timeout_look_neither_spins_nor_forgets_work(wires: Wires) -> None:
    selector = learned(wires).selector
    assert selector.select(0) == []  # asyncio with callbacks ready
    assert selector.polls == 0
    assert selector.select(0.002) == []  # the wait after them still spins
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


def test_a_socket_unregistered_and_registered_again_starts_unlearned(wires: Wires) -> None:
    learned(wires)
    reader = wires.pairs[1][0]
    wires.selector.unregister(reader)
    wires.selector.register(reader, selectors.EVENT_READ)
    assert wires.window(1) == 0
    assert wires.window(0) > 0


def test_room_to_write_on_another_socket_is_no_answer(wires: Wires) -> None:
    """An image going out in pieces alternates reads from the sim with room to write to ROS:
    a stream, which must not teach a spin."""
    wires.event(0)
    writer = wires.pairs[1][1]
    wires.selector.register(writer, selectors.EVENT_WRITE)
    ready = wires.selector.select(60.0)
    assert [(key.fileobj, events) for key, events in ready] == [(writer, selectors.EVENT_WRITE)]
    wires.selector.unregister(writer)
    assert wires.window(0) == 0
    wires.event(0)  # and the sim's next read is not an answer either
    assert wires.window(0) == 0
