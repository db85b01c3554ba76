"""Golden bytes, property tests and fuzzing of the TCPROS header and framing codec."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.protocol.tcpros import (
    MAX_HEADER_SIZE,
    TcprosDecoder,
    TcprosError,
    decode_header,
    encode_header,
    frame,
)

# A subscriber's header for std_msgs/String, byte by byte as rospy writes it (by name).
GOLDEN_HEADER = (
    b"\x3d\x00\x00\x00"  # header length 61 = 4 + 39 + 4 + 14
    b"\x27\x00\x00\x00"  # field length 39
    b"md5sum=992ce8a1687cec8c8bd883ec73ca41d1"
    b"\x0e\x00\x00\x00"  # field length 14
    b"topic=/chatter"
)


def test_golden_header() -> None:
    fields = {"topic": "/chatter", "md5sum": "992ce8a1687cec8c8bd883ec73ca41d1"}
    assert encode_header(fields) == GOLDEN_HEADER
    assert decode_header(GOLDEN_HEADER[4:]) == fields


def test_golden_message_frame() -> None:
    payload = struct.pack("<I", 5) + b"hello"  # std_msgs/String "hello"
    assert frame(payload) == b"\x09\x00\x00\x00\x05\x00\x00\x00hello"


def test_header_matches_rosgraph() -> None:
    """The same bytes as ROS's own encoder, decoded the same by ROS's own decoder."""
    network = pytest.importorskip("rosgraph.network")
    fields = {
        "callerid": "/talker",
        "topic": "/chatter",
        "md5sum": "992ce8a1687cec8c8bd883ec73ca41d1",
        "type": "std_msgs/String",
        "message_definition": "string data\n",
        "latching": "1",
        "tcp_nodelay": "0",
        "empty": "",
        "with_equals": "a=b=c",
    }
    ours = encode_header(fields)
    assert ours == network.encode_ros_handshake_header(fields)
    assert network.decode_ros_handshake_header(ours) == fields
    assert decode_header(ours[4:]) == fields


def test_decoder_splits_header_then_messages_at_any_boundary() -> None:
    wire = encode_header({"a": "1"}) + frame(b"x") + frame(b"") + frame(b"yz" * 100)
    for cut in range(len(wire) + 1):
        decoder = TcprosDecoder(max_message=1000)
        got = decoder.feed(wire[:cut]) + decoder.feed(wire[cut:])
        assert decoder.header == {"a": "1"}
        assert got == [b"x", b"", b"yz" * 100]
        assert decoder.pending == 0


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (b"\x01\x00", r"field length at byte 0 is cut short \(2 of 4 bytes\)"),
        (b"\x09\x00\x00\x00abc", r"claims 9 bytes, only 3 remain"),
        (b"\x03\x00\x00\x00abc", r"header field b'abc' is not name=value"),
        (b"\x02\x00\x00\x00=x", r"header field b'=x' is not name=value"),
        (b"\x03\x00\x00\x00a=\xff", r"is not UTF-8"),
    ],
)
def test_bad_header_bodies_name_the_fault(body: bytes, message: str) -> None:
    with pytest.raises(TcprosError, match=message):
        decode_header(body)
    with pytest.raises(TcprosError, match=message):
        TcprosDecoder(100).feed(struct.pack("<I", len(body)) + body)


def test_oversized_lengths_are_refused_before_buffering() -> None:
    with pytest.raises(TcprosError, match=r"connection header of 1048577 bytes is over"):
        TcprosDecoder(100).feed(struct.pack("<I", MAX_HEADER_SIZE + 1))
    decoder = TcprosDecoder(100)
    decoder.feed(encode_header({"a": "b"}))
    with pytest.raises(TcprosError, match=r"message of 101 bytes is over the limit of 100"):
        decoder.feed(struct.pack("<I", 101))


def test_encode_refuses_bad_names() -> None:
    with pytest.raises(TcprosError, match="must be non-empty without '='"):
        encode_header({"a=b": "c"})


names = st.text(st.characters(codec="utf-8", blacklist_characters="="), min_size=1)
values = st.text(st.characters(codec="utf-8"))


@given(st.dictionaries(names, values, max_size=8), st.lists(st.binary(max_size=300), max_size=8))
def test_round_trip(fields: dict[str, str], messages: list[bytes]) -> None:
    wire = encode_header(fields) + b"".join(frame(m) for m in messages)
    decoder = TcprosDecoder(max_message=1000)
    got: list[bytes] = []
    for start in range(0, len(wire), 7):
        got += decoder.feed(wire[start : start + 7])
    assert decoder.header == fields
    assert got == messages


@given(
    st.lists(st.binary(max_size=20) | st.binary(min_size=3000, max_size=9000), max_size=6),
    st.lists(st.integers(min_value=1, max_value=4000), min_size=1, max_size=50),
    st.sampled_from([bytes, bytearray, memoryview]),
)
def test_messages_cut_into_any_chunks(
    messages: list[bytes], sizes: list[int], kind: type[bytes | bytearray | memoryview]
) -> None:
    """Large messages arriving over many chunks, several frames in one chunk, lengths cut
    in two: every message comes out whole, as bytes, and `pending` counts what waits."""
    wire = encode_header({"a": "1"}) + b"".join(frame(m) for m in messages)
    decoder = TcprosDecoder(max_message=10_000)
    got: list[bytes] = []
    start = 0
    while start < len(wire):
        step = sizes[len(got) % len(sizes)]
        got += decoder.feed(kind(wire[start : start + step]))
        start = min(start + step, len(wire))
        done = sum(len(frame(m)) for m in got) + len(encode_header({"a": "1"}))
        if decoder.header is not None:
            assert decoder.pending == start - done
    assert decoder.header == {"a": "1"}
    assert got == messages
    assert all(type(m) is bytes for m in got)
    assert decoder.pending == 0


def test_a_read_of_one_whole_message_and_its_limit() -> None:
    """A read holding exactly one message (the shortcut) comes out as any other, and its
    length is held to the same limit."""
    decoder = TcprosDecoder(max_message=8)
    assert decoder.feed(encode_header({"a": "1"}) + frame(b"x")) == [b"x"]
    assert decoder.feed(frame(b"12345678")) == [b"12345678"]
    assert decoder.feed(bytearray(frame(b""))) == [b""]
    assert decoder.feed(frame(b"ab") + frame(b"c")) == [b"ab", b"c"]
    assert decoder.feed(frame(b"abc")[:5]) == []  # a message cut short waits for the rest
    assert decoder.feed(frame(b"abc")[5:] + frame(b"d")) == [b"abc", b"d"]
    with pytest.raises(TcprosError, match="9 bytes is over the limit of 8"):
        decoder.feed(frame(b"123456789"))


@settings(max_examples=500)
@given(st.lists(st.binary(max_size=64), max_size=10))
def test_fuzz_never_crashes(chunks: list[bytes]) -> None:
    """Any bytes: messages, waiting for more, or TcprosError; never another exception."""
    decoder = TcprosDecoder(max_message=4096)
    try:
        for chunk in chunks:
            for message in decoder.feed(chunk):
                assert len(message) <= 4096
    except TcprosError:
        return
    assert decoder.pending < MAX_HEADER_SIZE + 4


@settings(max_examples=300)
@given(st.binary(max_size=200))
def test_fuzz_header_bodies(body: bytes) -> None:
    error = ""
    try:
        fields = decode_header(body)
    except TcprosError as exc:
        error = str(exc)
    if error:
        assert "header field" in error
        return
    assert decode_header(encode_header(fields)[4:]) == fields
