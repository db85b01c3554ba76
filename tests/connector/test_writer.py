"""Framer golden bytes, batching without copies of large payloads, partial sendmsg."""

from __future__ import annotations

import threading
from collections.abc import Sequence

from simbridge.connector.fifo import BoundedFifo
from simbridge.connector.framer import Framer
from simbridge.connector.link import Link
from simbridge.connector.stats import StatsCounters
from simbridge.connector.writer import FrameWriter, OutTopic, send_buffers
from simbridge.protocol import Subscribe


def test_ros1_frames_golden() -> None:
    framer = Framer("ROS1")
    assert framer.message("/a", b"xyz") == (
        b"\x02\x00\x00\x00"  # destination length 2
        b"/a"  # destination
        b"\x03\x00\x00\x00"  # payload length 3
        b"xyz"
    )
    assert framer.command(Subscribe("/a", "std_msgs/String")) == (
        b"\x0b\x00\x00\x00__subscribe"
        b"\x32\x00\x00\x00"  # 50 bytes of JSON
        b'{"topic": "/a", "message_name": "std_msgs/String"}'
    )
    assert framer.service_request(7, "/s", b"q") == (
        b'\x09\x00\x00\x00__request\x0d\x00\x00\x00{"srv_id": 7}\x02\x00\x00\x00/s\x01\x00\x00\x00q'
    )


def test_ros2_frames_carry_trailing_nuls() -> None:
    framer = Framer("ROS2")
    assert framer.message("/a", b"\x00\x01\x00\x00") == (
        b"\x03\x00\x00\x00/a\x00"  # name + NUL, counted
        b"\x04\x00\x00\x00\x00\x01\x00\x00"  # CDR payload untouched
    )
    assert framer.service_response(3, "/s", b"") == (
        b'\x0b\x00\x00\x00__response\x00\x0e\x00\x00\x00{"srv_id": 3}\x00'
        b"\x03\x00\x00\x00/s\x00\x00\x00\x00\x00"
    )


def test_pack_copies_small_payloads_and_passes_large_ones_through() -> None:
    topic = OutTopic("/img", Framer("ROS1").prefix("/img"), 10)
    big = bytes(200_000)
    parts = FrameWriter._pack([(None, b"CMD"), (topic, b"small"), (topic, big), (topic, b"s2")])
    assert parts[1] is big  # no copy of the image
    assert b"".join(parts) == (
        b"CMD"
        + b"\x04\x00\x00\x00/img\x05\x00\x00\x00small"
        + b"\x04\x00\x00\x00/img\x40\x0d\x03\x00"
        + big
        + b"\x04\x00\x00\x00/img\x02\x00\x00\x00s2"
    )


class TrickleSocket:
    """`sendmsg` that accepts at most `limit` bytes per call."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.data = bytearray()
        self.calls = 0

    def sendmsg(self, buffers: Sequence[bytes | bytearray | memoryview]) -> int:
        self.calls += 1
        assert len(buffers) <= 1024
        joined = b"".join(bytes(b) for b in buffers)[: self.limit]
        self.data += joined
        return len(joined)


def test_send_buffers_survives_partial_sends() -> None:
    sock = TrickleSocket(limit=7)
    parts: list[bytes | bytearray | memoryview] = [
        b"abc",
        bytearray(b"defgh"),
        b"",
        b"ijklmnopqrstu",
        b"v",
    ]
    link = Link(sock)  # type: ignore[arg-type]
    assert send_buffers(link, parts) == 22
    assert bytes(sock.data) == b"abcdefghijklmnopqrstuv"
    assert sock.calls == 4


def test_send_buffers_splits_beyond_iov_max() -> None:
    sock = TrickleSocket(limit=1 << 30)
    parts = [bytes([i % 256]) for i in range(2500)]
    assert send_buffers(Link(sock), parts) == 2500  # type: ignore[arg-type]
    assert sock.calls == 3
    assert bytes(sock.data) == b"".join(parts)


def test_writer_thread_batches_and_counts() -> None:
    sock = TrickleSocket(limit=1 << 30)
    fifo: BoundedFifo[OutTopic, bytes] = BoundedFifo()
    counters = StatsCounters()
    writer = FrameWriter(fifo, counters, keepalive=10.0)
    topic = OutTopic("/t", Framer("ROS1").prefix("/t"), 1000)
    for i in range(100):
        fifo.put(topic, bytes([i]), topic.bound, 1)
    writer.start()
    writer.attach(Link(sock))  # type: ignore[arg-type]
    done = threading.Event()
    for _ in range(500):
        if writer.idle and counters.frames_sent == 100:
            done.set()
            break
        threading.Event().wait(0.01)
    writer.stop()
    assert done.is_set()
    assert sock.calls == 1  # one sendmsg for all 100 frames
    assert bytes(sock.data) == b"".join(
        Framer("ROS1").message("/t", bytes([i])) for i in range(100)
    )
    assert counters.bytes_sent == len(sock.data)
