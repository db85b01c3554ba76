"""FrameReader gives the same events as ProtocolConnection, however the stream is split."""

from __future__ import annotations

import socket
import struct

from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.connector.reader import FrameReader
from simbridge.protocol import (
    KEEPALIVE,
    ErrorMessage,
    Event,
    Handshake,
    MessageReceived,
    ProtocolConnection,
    ProtocolViolation,
    TopicListReply,
    encode_frame,
)


class ChunkSocket:
    """Hands out a byte string in fixed chunks through `recv_into`, like a socket."""

    def __init__(self, data: bytes, cuts: list[int]) -> None:
        points = sorted({c % (len(data) + 1) for c in cuts} | {len(data)})
        self.chunks: list[bytes] = []
        start = 0
        for point in points:
            if point > start:
                self.chunks.append(data[start:point])
                start = point

    def recv_into(self, view: memoryview) -> int:
        if not self.chunks:
            return 0
        chunk = self.chunks[0]
        n = min(len(view), len(chunk))
        view[:n] = chunk[:n]
        if n == len(chunk):
            self.chunks.pop(0)
        else:
            self.chunks[0] = chunk[n:]
        return n


def read_all(data: bytes, cuts: list[int], chunk: int = 64) -> list[Event]:
    reader = FrameReader(ProtocolConnection("client"), 1 << 20, chunk)
    sock = ChunkSocket(data, cuts)
    events: list[Event] = []
    while True:
        count, items = reader.receive(sock)  # type: ignore[arg-type]
        if not count:
            break
        for item in items:
            events.append(MessageReceived(*item) if isinstance(item, tuple) else item)
    assert reader.buffered == 0
    return events


frames = st.one_of(
    st.builds(
        encode_frame,
        st.sampled_from(["/a", "/cmd_vel", "/camera/image_raw", "/é", "x"]),
        st.binary(max_size=300),
    ),
    st.just(KEEPALIVE),
    st.builds(lambda text: ErrorMessage(text).encode(), st.text(max_size=20)),
    st.builds(
        lambda srv_id, payload: ProtocolConnection.service_response(srv_id, "/srv", payload),
        st.integers(0, 2**31),
        st.binary(max_size=50),
    ),
    st.just(Handshake().encode()),
    st.just(TopicListReply(("/a",), ("std_msgs/String",)).encode()),
)


@settings(max_examples=150, deadline=None)
@given(st.lists(frames, max_size=25), st.lists(st.integers(0, 10_000), max_size=30))
def test_same_events_as_protocol_connection(parts: list[bytes], cuts: list[int]) -> None:
    stream = b"".join(parts)
    expected = ProtocolConnection("client").receive_data(stream)
    assert read_all(stream, cuts) == expected


bursts = st.one_of(
    st.builds(lambda p: encode_frame("/a", p), st.binary(min_size=8, max_size=8)),
    st.builds(lambda p: encode_frame("/b", p), st.binary(min_size=8, max_size=9)),
    # a service frame whose header repeats the burst's (after its __response header)
    st.builds(
        lambda payload: ProtocolConnection.service_response(7, "/a", payload),
        st.binary(min_size=8, max_size=8),
    ),
    st.just(KEEPALIVE),
)


@settings(max_examples=150, deadline=None)
@given(st.lists(bursts, max_size=60), st.lists(st.integers(0, 10_000), max_size=30))
def test_bursts_of_repeated_headers_give_the_same_events(
    parts: list[bytes], cuts: list[int]
) -> None:
    """Frames repeating the last message's header (read by one comparison) still give
    ProtocolConnection's events, service frames with that header included."""
    stream = b"".join(parts)
    expected = ProtocolConnection("client").receive_data(stream)
    assert read_all(stream, cuts) == expected


def test_large_frame_grows_the_buffer_and_survives() -> None:
    big = bytes(range(256)) * 4000
    stream = encode_frame("/img", big) + encode_frame("/a", b"x") + encode_frame("/img", big)
    events = read_all(stream, list(range(0, len(stream), 1500)), chunk=4096)
    assert events == [
        MessageReceived("/img", big),
        MessageReceived("/a", b"x"),
        MessageReceived("/img", big),
    ]


def test_oversized_length_prefix_is_fatal_without_allocating() -> None:
    reader = FrameReader(ProtocolConnection("client"), 1000, 64)
    stream = struct.pack("<I", 2) + b"/a" + struct.pack("<I", 1001)
    _, items = reader.receive(ChunkSocket(stream, []))  # type: ignore[arg-type]
    assert items == [
        ProtocolViolation("payload length 1001 bytes exceeds the limit of 1000 bytes", fatal=True)
    ]


def test_reads_from_a_real_socket() -> None:
    a, b = socket.socketpair()
    with a, b:
        a.sendall(encode_frame("/t", b"hello") + KEEPALIVE)
        reader = FrameReader(ProtocolConnection("client"), 1 << 20, 1 << 20)
        count, items = reader.receive(b)
        assert count == 4 + 2 + 4 + 5 + 8
        assert items[0] == ("/t", b"hello")
        assert len(items) == 2


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.integers(0, 5000), min_size=1, max_size=40),
    st.lists(st.integers(0, 200_000), max_size=30),
    st.integers(1, 700),
)
def test_payloads_of_every_size_come_out_whole_as_bytes(
    sizes: list[int], cuts: list[int], start: int
) -> None:
    """Small payloads (one cached unpacker per size, and past the cache's bound) and
    large ones (copied out), many to one read or cut anywhere: each is its own bytes."""
    payloads = [bytes((start + i + j) % 251 for j in range(size)) for i, size in enumerate(sizes)]
    stream = b"".join(encode_frame("/t", p) for p in payloads)
    reader = FrameReader(ProtocolConnection("client"), 1 << 20, 4096)
    for size in range(1, 600):  # fill the unpacker cache so later sizes go uncached
        reader._unpacker(size)
    sock = ChunkSocket(stream, cuts)
    got: list[object] = []
    while True:
        count, items = reader.receive(sock)  # type: ignore[arg-type]
        if not count:
            break
        got += items
    assert got == [("/t", p) for p in payloads]
    assert all(type(item[1]) is bytes for item in got if isinstance(item, tuple))
