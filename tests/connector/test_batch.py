"""Publish batches (`Connector.batch`): one write per batch from the publishing thread when
nothing waits before it, the writer thread otherwise; order, drops and counters kept."""

from __future__ import annotations

import dataclasses
import socket
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from simbridge.connector import ConnectorOptions
from simbridge.connector.fifo import BoundedFifo
from simbridge.connector.framer import Framer
from simbridge.connector.link import Link
from simbridge.connector.stats import StatsCounters
from simbridge.connector.writer import FrameWriter, OutTopic
from simbridge.protocol import CommandReceived, MessageReceived, Publish, RemovePublisher
from tests.connector.conftest import FAST, read_exactly
from tests.connector.fake_endpoint import FakeEndpoint
from tests.waiting import wait_for

FRAMER = Framer("ROS1")


def _topic(name: str, bound: int = 1000) -> OutTopic:
    return OutTopic(name, FRAMER.prefix(name), bound)


# ---- BoundedFifo.put_many_or_send ---------------------------------------------------------


def test_send_is_tried_only_while_nothing_is_queued() -> None:
    fifo: BoundedFifo[str, bytes] = BoundedFifo()
    tried: list[list[bytes]] = []

    def send(entries: Sequence[tuple[str, bytes, int]]) -> list[bytes]:
        tried.append([item for _, item, _ in entries])
        return []

    assert fifo.put_many_or_send([("a", b"1", 5), ("b", b"2", 5)], send) == []
    assert tried == [[b"1", b"2"]]
    assert len(fifo) == 0
    assert not fifo.ready.is_set()
    fifo.put_control(b"cmd")
    fifo.put_many_or_send([("a", b"3", 5)], send)
    assert tried == [[b"1", b"2"]]  # something waited: queued behind it, not sent
    assert fifo.take(10, 1 << 20) == [(None, b"cmd"), ("a", b"3")]


def test_declined_send_queues_with_bounds_and_a_partial_one_queues_the_rest() -> None:
    fifo: BoundedFifo[str, bytes] = BoundedFifo()
    fifo.ready.clear()
    dropped = fifo.put_many_or_send([("a", b"1", 1), ("a", b"2", 1)], lambda _e: None)
    assert dropped == ["a"]
    assert fifo.ready.is_set()
    assert fifo.take(10, 1 << 20) == [("a", b"2")]
    fifo.ready.clear()
    assert fifo.put_many_or_send([("a", b"x", 1)], lambda _e: [b"tail", b"frame"]) == []
    assert fifo.ready.is_set()
    assert fifo.pending("a") == 0
    assert fifo.take(10, 1 << 20) == [(None, b"tail"), (None, b"frame")]


# ---- FrameWriter.write_batch ---------------------------------------------------------------


Parts = tuple[FrameWriter, BoundedFifo[OutTopic, bytes], StatsCounters]


def _writer(keepalive: float = 10.0) -> Parts:
    fifo: BoundedFifo[OutTopic, bytes] = BoundedFifo()
    counters = StatsCounters()
    return FrameWriter(fifo, counters, keepalive), fifo, counters


def test_small_batch_is_written_by_the_caller(pair: tuple[socket.socket, socket.socket]) -> None:
    writer, fifo, counters = _writer()  # the thread is never started: nothing else writes
    writer.attach(Link(pair[0]))
    js, clock = _topic("/joint_states"), _topic("/clock")
    assert writer.write_batch([(js, b"JS", 10), (clock, b"\x01\x02", 10)]) == []
    expected = FRAMER.message("/joint_states", b"JS") + FRAMER.message("/clock", b"\x01\x02")
    assert read_exactly(pair[1], len(expected)) == expected
    assert len(fifo) == 0
    assert writer.idle
    assert (counters.direct_frames_sent, counters.direct_bytes_sent) == (2, len(expected))


def test_batch_waits_behind_queued_frames_and_without_a_link(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    writer, fifo, counters = _writer()
    topic = _topic("/t")
    writer.write_batch([(topic, b"early", 10)])  # no connection yet: queued
    writer.attach(Link(pair[0]))
    writer.write_batch([(topic, b"late", 10)])  # "early" still waits: queued behind it
    assert len(fifo) == 2
    assert counters.direct_frames_sent == 0
    writer.start()
    try:
        expected = FRAMER.message("/t", b"early") + FRAMER.message("/t", b"late")
        assert read_exactly(pair[1], len(expected)) == expected
    finally:
        writer.stop()


def test_large_batch_goes_to_the_writer_thread(pair: tuple[socket.socket, socket.socket]) -> None:
    writer, fifo, counters = _writer()
    writer.attach(Link(pair[0]))
    image = bytes(range(256)) * 1024  # 256 KiB: over the direct limit
    writer.write_batch([(_topic("/img"), image, 10)])
    assert len(fifo) == 1
    assert counters.direct_frames_sent == 0


def test_full_socket_buffer_queues_the_unsent_rest_in_order(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    a, b = pair
    a.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 4096)
    b.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    writer, fifo, counters = _writer()
    writer.attach(Link(a))
    topic = _topic("/t", bound=100_000)
    frames: list[bytes] = []
    batches = 0
    while len(fifo) == 0:  # until a send falls short of a batch or is refused
        payloads = [bytes([batches % 256]) * 700, bytes([(batches + 1) % 256]) * 300]
        writer.write_batch([(topic, p, 100_000) for p in payloads])
        frames += [FRAMER.message("/t", p) for p in payloads]
        batches += 1
        assert batches < 10_000, "the socket never filled"
    for i in range(20):  # more batches now wait behind the queued rest
        payload = b"after%d" % i
        writer.write_batch([(topic, payload, 100_000)])
        frames.append(FRAMER.message("/t", payload))
    writer.start()
    try:
        expected = b"".join(frames)
        # (generous: the writer thread may wait long for the CPU on a loaded machine)
        assert read_exactly(b, len(expected), timeout=60) == expected  # none lost or reordered
        assert wait_for(lambda: writer.idle)
        assert wait_for(lambda: counters.bytes_sent + counters.direct_bytes_sent == len(expected))
        assert counters.frames_sent + counters.direct_frames_sent == len(frames)
    finally:
        writer.stop()


@given(st.lists(st.integers(0, 3000), min_size=1, max_size=12), st.integers(0, 20_000))
def test_partial_send_splits_at_the_right_byte(sizes: list[int], accept: int) -> None:
    """Whatever prefix the kernel takes, sent bytes + queued rest == the batch's frames."""

    class Sock:
        def __init__(self) -> None:
            self.data = b""

        def send(self, data: Any, flags: int = 0) -> int:
            self.data = bytes(data[:accept])
            if not self.data:
                raise BlockingIOError
            return len(self.data)

    writer, fifo, counters = _writer()
    sock = Sock()
    writer.attach(Link(sock))  # type: ignore[arg-type]
    topic = _topic("/t", bound=100)
    payloads = [bytes([i % 256]) * size for i, size in enumerate(sizes)]
    writer.write_batch([(topic, p, 100) for p in payloads])
    frames = [FRAMER.message("/t", p) for p in payloads]
    queued = [item for _, item in fifo.take(1000, 1 << 30)]
    if not sock.data:  # refused: everything queued as published messages
        assert queued == payloads
        return
    assert sock.data + b"".join(queued) == b"".join(frames)
    whole = 0
    for frame in frames:
        if accept >= len(frame):
            accept -= len(frame)
            whole += 1
        else:
            break
    assert counters.direct_frames_sent == whole
    assert len(queued) == len(frames) - whole


# ---- Connector.batch -----------------------------------------------------------------------


def _messages(endpoint: FakeEndpoint, topic: str) -> list[bytes]:
    return [
        bytes(e.payload)
        for e in endpoint.events()
        if isinstance(e, MessageReceived) and e.topic == topic
    ]


def test_connector_batch_sends_at_the_end_in_order(
    endpoint: FakeEndpoint, make_connector: Callable[..., Any]
) -> None:
    # frames_sent counts keepalives too: none may go out between the counts (a 0.2 s
    # interval is exceeded by any stall of a busy box)
    options = dataclasses.replace(FAST, keepalive_interval=3600.0)
    conn = make_connector(endpoint.port, options).connect()
    a = conn.register_publisher("/a", "std_msgs/String")
    b = conn.register_publisher("/b", "std_msgs/String")
    assert wait_for(lambda: conn.flush(0) and len(conn._out) == 0)
    before = conn.stats().frames_sent
    with conn.batch():
        a.publish(b"1")
        with conn.batch():  # nested: the outer one sends
            b.publish(b"2")
        a.publish(b"3")
        time.sleep(0.05)
        assert conn.stats().frames_sent == before  # nothing left yet
    assert endpoint.wait_for(lambda: len(_messages(endpoint, "/a")) == 2)
    assert _messages(endpoint, "/a") == [b"1", b"3"]
    assert _messages(endpoint, "/b") == [b"2"]
    order = [e.topic for e in endpoint.events() if isinstance(e, MessageReceived)]
    assert order == ["/a", "/b", "/a"]
    assert conn.stats().frames_sent == before + 3


def test_batch_is_per_thread_and_messages_precede_a_later_unregister(
    endpoint: FakeEndpoint, make_connector: Callable[..., Any]
) -> None:
    conn = make_connector(endpoint.port).connect()
    pub = conn.register_publisher("/a", "std_msgs/String")
    with conn.batch():
        pub.publish(b"held")
        other = threading.Thread(target=pub.publish, args=(b"other thread",))
        other.start()
        other.join()
        assert endpoint.wait_for(lambda: _messages(endpoint, "/a") == [b"other thread"])
        conn.unregister_publisher("/a")  # the batch's message goes first
    assert endpoint.wait_for(
        lambda: any(
            isinstance(e, CommandReceived) and isinstance(e.command, RemovePublisher)
            for e in endpoint.events()
        )
    )
    kinds = [
        ("msg", e.payload) if isinstance(e, MessageReceived) else ("cmd", type(e.command).__name__)
        for e in endpoint.events()
        if isinstance(e, MessageReceived | CommandReceived)
    ]
    assert kinds == [
        ("cmd", Publish.__name__),
        ("msg", b"other thread"),
        ("msg", b"held"),
        ("cmd", RemovePublisher.__name__),
    ]


def test_batch_drops_past_the_topic_bound_are_counted(make_connector: Callable[..., Any]) -> None:
    conn = make_connector(1, ConnectorOptions(publish_queue_size=2))  # never connected
    pub = conn.register_publisher("/a", "std_msgs/String")
    with conn.batch():
        for i in range(5):
            pub.publish(bytes([i]))
    assert conn.stats().publish_drops == {"/a": 3}
