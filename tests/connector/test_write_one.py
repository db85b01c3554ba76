"""Single publishes (`FrameWriter.write_one`): a message on its own is written by the
publishing thread (no hand-off to the writer thread on a round trip); a burst is left to
the writer thread, in order, with the topic's bound."""

from __future__ import annotations

import socket

import pytest

from simbridge.connector import writer as writer_module
from simbridge.connector.fifo import BoundedFifo
from simbridge.connector.framer import Framer
from simbridge.connector.link import Link
from simbridge.connector.stats import StatsCounters
from simbridge.connector.writer import FrameWriter, OutTopic
from tests.connector.conftest import read_exactly

FRAMER = Framer("ROS1")


def _writer() -> tuple[FrameWriter, BoundedFifo[OutTopic, bytes], StatsCounters]:
    fifo: BoundedFifo[OutTopic, bytes] = BoundedFifo()
    counters = StatsCounters()
    return FrameWriter(fifo, counters, 10.0), fifo, counters


def test_a_message_on_its_own_is_written_by_the_caller(
    pair: tuple[socket.socket, socket.socket], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(writer_module, "_BURST_GAP", 0.0)  # every message stands alone
    writer, fifo, counters = _writer()  # the thread is never started: nothing else writes
    writer.attach(Link(pair[0]))
    topic = OutTopic("/ping", FRAMER.prefix("/ping"), 10)
    for payload in (b"one", b"two"):
        assert writer.write_one(topic, payload) is False
        frame = FRAMER.message("/ping", payload)
        assert read_exactly(pair[1], len(frame)) == frame
    assert len(fifo) == 0
    assert counters.direct_frames_sent == 2


def test_a_burst_is_left_to_the_writer_thread_in_order_and_bounded(
    pair: tuple[socket.socket, socket.socket], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(writer_module, "_BURST_GAP", 3600.0)  # all follow the first closely
    writer, fifo, counters = _writer()
    writer.attach(Link(pair[0]))
    topic = OutTopic("/cmd", FRAMER.prefix("/cmd"), 3)
    dropped = [writer.write_one(topic, b"%d" % i) for i in range(6)]
    assert counters.direct_frames_sent == 1  # the first went at once
    assert dropped == [False, False, False, False, True, True]  # bound 3: "1" and "2" dropped
    assert len(fifo) == 3
    writer.start()
    try:
        expected = b"".join(FRAMER.message("/cmd", b"%d" % i) for i in (0, 3, 4, 5))
        assert read_exactly(pair[1], len(expected)) == expected
    finally:
        writer.stop()


def test_a_large_message_or_one_behind_queued_frames_is_not_written_by_the_caller(
    pair: tuple[socket.socket, socket.socket], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(writer_module, "_BURST_GAP", 0.0)
    writer, fifo, counters = _writer()
    writer.attach(Link(pair[0]))
    image = OutTopic("/img", FRAMER.prefix("/img"), 10)
    big = bytes(range(256)) * 1024  # 256 KiB: over the direct limit
    writer.write_one(image, big)
    small = OutTopic("/t", FRAMER.prefix("/t"), 10)
    writer.write_one(small, b"after")  # the image still waits: queued behind it
    assert len(fifo) == 2
    assert counters.direct_frames_sent == 0
    writer.start()
    try:
        expected = FRAMER.message("/img", big) + FRAMER.message("/t", b"after")
        assert read_exactly(pair[1], len(expected)) == expected
    finally:
        writer.stop()
