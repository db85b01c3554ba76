"""BusyPollSelector: learns to spin for answers on another socket, not for streams or long
waits; never spins past asyncio's timeout or its duty cap; an asyncio loop on it serves as
the default one does."""

from __future__ import annotations

import asyncio
import selectors
import socket
import threading
import time
from collections.abc import Iterator

import pytest

from simbridge.endpoint.speed.busypoll import MAX_BUSY_POLL_US, BusyPollSelector
from simbridge.errors import EndpointError

LIMIT_US = 50_000
"""Limit of the selectors under test (50 ms): wide enough for thread timers' jitter."""


class Wires:
    """Two socket pairs (as a sim client and a ROS node) watched by one selector."""

    def __init__(self, selector: BusyPollSelector) -> None:
        self.selector = selector
        self.pairs = [socket.socketpair(), socket.socketpair()]
        for reader, _ in self.pairs:
            selector.register(reader, selectors.EVENT_READ)

    def send_later(self, which: int, delay: float) -> tuple[threading.Thread, threading.Event]:
        """A byte on pair `which` `delay` s after the returned event is set (set it right
        before selecting, so a loaded machine's late start does not shorten the wait)."""
        armed = threading.Event()

        def send() -> None:
            armed.wait()
            time.sleep(delay)
            self.pairs[which][1].send(b"x")

        thread = threading.Thread(target=send)
        thread.start()
        return thread, armed

    def wait(self, which: int, delay: float, timeout: float | None = 1.0) -> None:
        """An event on pair `which` after `delay` s; the selector must return it."""
        thread, armed = self.send_later(which, delay)
        armed.set()
        ready = self.selector.select(timeout)
        thread.join()
        assert [key.fileobj for key, _ in ready] == [self.pairs[which][0]]
        self.pairs[which][0].recv(16)

    def close(self) -> None:
        for reader, writer in self.pairs:
            reader.close()
            writer.close()


@pytest.fixture
def wires() -> Iterator[Wires]:
    with BusyPollSelector(LIMIT_US) as selector:
        w = Wires(selector)
        yield w
        w.close()


def learned(wires: Wires, delay: float = 0.01) -> Wires:
    """Work on pair 0, answered on pair 1 `delay` s later, and that answered on pair 0: a spin
    of twice `delay` is learned after each, and the next event awaited is on pair 1."""
    wires.wait(0, 0)
    wires.wait(1, delay)
    wires.wait(0, delay)
    for reader, _ in wires.pairs:
        # twice the wait it saw, which starts a moment after the sender's clock does
        assert wires.selector.window(reader) >= 2 * delay * 0.9
    assert wires.selector.polls == 0
    return wires


def window(wires: Wires, which: int) -> float:
    return wires.selector.window(wires.pairs[which][0])


@pytest.mark.parametrize("limit_us", [-1, MAX_BUSY_POLL_US + 1, float("nan")])
def test_out_of_range_limit_is_refused_naming_it(limit_us: float) -> None:
    with pytest.raises(EndpointError, match=f"busy-poll time {limit_us!r}.*expected 0 to 100000"):
        BusyPollSelector(limit_us)


@pytest.mark.parametrize("duty", [0, -0.5, 1.5])
def test_out_of_range_duty_is_refused_naming_it(duty: float) -> None:
    with pytest.raises(EndpointError, match=f"busy-poll duty {duty!r}.*expected"):
        BusyPollSelector(100, duty)


def test_an_idle_loop_blocks_without_spinning(wires: Wires) -> None:
    started = time.perf_counter()
    assert wires.selector.select(0.05) == []
    assert time.perf_counter() - started >= 0.04
    assert wires.selector.polls == 0
    assert wires.selector.spin_seconds == 0


def test_an_answer_within_the_limit_teaches_a_spin_that_catches_the_next(wires: Wires) -> None:
    selector = learned(wires).selector
    wires.wait(1, 0.003)  # the next answer: found by polling, not by sleeping
    assert selector.hits == 1
    assert selector.polls > 1
    assert 0.002 <= selector.spin_seconds < 0.05


def test_a_stream_on_one_socket_never_spins(wires: Wires) -> None:
    for _ in range(6):
        wires.wait(0, 0.003)
    assert window(wires, 0) == 0
    assert wires.selector.polls == 0


def test_a_spin_that_finds_the_same_socket_again_shrinks(wires: Wires) -> None:
    selector = learned(wires).selector
    before = window(wires, 0)
    wires.wait(0, 0.002)  # pair 0 again: a stream, not an answer
    assert selector.hits == 1
    assert window(wires, 0) == before / 2


def test_a_wait_past_the_limit_turns_the_spin_off(wires: Wires) -> None:
    selector = learned(wires).selector
    wires.wait(1, 0.08)  # spins, finds nothing, then sleeps past the 50 ms limit
    assert (selector.polls > 0, selector.hits) == (True, 0)
    assert window(wires, 0) == 0
    wires.wait(0, 0.002)  # after pair 1: still spins
    assert selector.hits == 1
    polls = selector.polls
    wires.wait(1, 0.002)  # after pair 0: sleeps at once
    assert selector.polls == polls


def test_a_spin_that_finds_nothing_in_its_window_is_a_miss(wires: Wires) -> None:
    selector = learned(wires, 0.002).selector
    wires.wait(1, 0.04)  # the answer comes late, but within the limit: the window grows to it
    assert (selector.hits, selector.misses) == (0, 1)
    assert window(wires, 0) == 0.05


def test_a_spin_ends_at_asyncio_timeout_and_the_next_wait_sleeps(wires: Wires) -> None:
    selector = learned(wires).selector
    learned_window = window(wires, 1)
    assert selector.select(0.002) == []
    # the spin was cut to the timeout: a spin of the whole window that finds nothing would
    # count a miss and shrink the window
    assert (selector.hits, selector.misses) == (0, 0)
    assert window(wires, 1) == learned_window
    polls = selector.polls
    assert polls > 0
    assert selector.select(0.002) == []  # nothing came: no more spinning
    assert selector.polls == polls


def test_a_zero_timeout_look_neither_spins_nor_forgets_work(wires: Wires) -> None:
    selector = learned(wires).selector
    assert selector.select(0) == []  # asyncio with callbacks ready
    assert selector.polls == 0
    assert selector.select(0.002) == []  # the wait after them still spins
    assert selector.polls > 0


def test_spinning_takes_at_most_its_duty_share_of_wall_time() -> None:
    with BusyPollSelector(LIMIT_US, duty=0.1) as selector:
        wires = Wires(selector)
        try:
            learned(wires)
            started = time.perf_counter()
            for i in range(40):  # a closed loop whose answers take 5 ms: worth a full spin
                wires.wait((i + 1) % 2, 0.005)
            elapsed = time.perf_counter() - started
        finally:
            wires.close()
    assert selector.hits > 0
    assert selector.spin_seconds <= 0.1 * elapsed + 0.02 + 0.005  # duty, burst, one poll


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
    assert window(wires, 1) == 0
    assert window(wires, 0) > 0


def test_room_to_write_on_another_socket_is_no_answer(wires: Wires) -> None:
    """An image going out in pieces alternates reads from the sim with room to write to ROS:
    a stream, which must not teach a spin."""
    wires.wait(0, 0)
    writer = wires.pairs[1][1]
    wires.selector.register(writer, selectors.EVENT_WRITE)
    ready = wires.selector.select(1.0)
    assert [(key.fileobj, events) for key, events in ready] == [(writer, selectors.EVENT_WRITE)]
    wires.selector.unregister(writer)
    assert window(wires, 0) == 0
    wires.wait(0, 0.002)  # and the sim's next read is not an answer either
    assert window(wires, 0) == 0
