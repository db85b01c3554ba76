"""Golden bytes and property tests of ROS-TCP framing."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from simbridge.errors import ProtocolError
from simbridge.protocol import KEEPALIVE, Frame, FrameDecoder, FrameTooLargeError, encode_frame


def test_golden_topic_frame() -> None:
    payload = struct.pack("<d", 0.5)
    expected = (
        b"\x08\x00\x00\x00"  # uint32 LE: destination length 8
        b"/cmd_vel"  # destination, UTF-8
        b"\x08\x00\x00\x00"  # uint32 LE: payload length 8
        b"\x00\x00\x00\x00\x00\x00\xe0\x3f"  # payload: float64 0.5
    )
    assert encode_frame("/cmd_vel", payload) == expected
    assert FrameDecoder().feed(expected) == [Frame("/cmd_vel", payload)]


def test_golden_keepalive() -> None:
    assert KEEPALIVE == (
        b"\x00\x00\x00\x00"  # destination length 0
        b"\x00\x00\x00\x00"  # payload length 0
    )
    (frame,) = FrameDecoder().feed(KEEPALIVE)
    assert frame.is_keepalive
    assert not frame.is_command


def test_ros2_trailing_nuls_are_stripped_from_destination() -> None:
    data = (
        b"\x06\x00\x00\x00"  # destination length 6, the trailing NUL counted (ROS 2 client)
        b"/odom\x00"  # destination with its NUL
        b"\x00\x00\x00\x00"  # payload length 0
    )
    assert FrameDecoder().feed(data) == [Frame("/odom", b"")]


def test_split_delivery_byte_by_byte() -> None:
    data = encode_frame("a", b"xyz") + encode_frame("__topic_list", b"{}") + KEEPALIVE
    decoder = FrameDecoder()
    frames: list[Frame] = []
    for i in range(len(data)):
        frames += decoder.feed(data[i : i + 1])
    assert frames == [Frame("a", b"xyz"), Frame("__topic_list", b"{}"), Frame("", b"")]
    assert decoder.buffered == 0


def test_oversized_payload_is_refused_before_reading_it() -> None:
    decoder = FrameDecoder(max_payload=1024)
    header = b"\x01\x00\x00\x00t" + struct.pack("<I", 0xFFFFFFF0)
    with pytest.raises(FrameTooLargeError, match="4294967280"):
        decoder.feed(header)
    with pytest.raises(FrameTooLargeError):
        decoder.feed(b"more")


def test_oversized_destination_is_refused() -> None:
    with pytest.raises(FrameTooLargeError, match="destination length"):
        FrameDecoder(max_destination=16).feed(struct.pack("<I", 17))


def test_non_utf8_destination() -> None:
    with pytest.raises(ProtocolError, match="UTF-8"):
        FrameDecoder().feed(b"\x02\x00\x00\x00\xff\xfe\x00\x00\x00\x00")


frames_strategy = st.lists(
    st.tuples(
        st.text(
            alphabet=st.characters(blacklist_categories=["Cs"], blacklist_characters="\x00"),
            max_size=20,
        ),
        st.binary(max_size=300),
    ),
    max_size=20,
)


@given(frames_strategy, st.lists(st.integers(min_value=1, max_value=64), min_size=1))
def test_round_trip_any_chunking(frames: list[tuple[str, bytes]], cuts: list[int]) -> None:
    data = b"".join(encode_frame(d, p) for d, p in frames)
    decoder = FrameDecoder()
    out: list[Frame] = []
    pos = 0
    i = 0
    while pos < len(data):
        step = cuts[i % len(cuts)]
        out += decoder.feed(data[pos : pos + step])
        pos += step
        i += 1
    assert [(f.destination, f.payload) for f in out] == frames


@given(st.binary(max_size=2000))
def test_fuzz_decoder_never_raises_unexpected(data: bytes) -> None:
    decoder = FrameDecoder(max_payload=4096)
    try:
        frames = decoder.feed(data)
    except ProtocolError:
        return
    assert sum(8 + len(f.destination.encode()) + len(f.payload) for f in frames) <= len(data)


def _receive_into(decoder: FrameDecoder, data: bytes, chunk: int) -> list[Frame]:
    frames: list[Frame] = []
    pos = 0
    while pos < len(data):
        target = decoder.get_buffer()
        n = min(len(target), chunk, len(data) - pos)
        target[:n] = data[pos : pos + n]
        frames += decoder.buffer_updated(n)
        pos += n
    return frames


@pytest.mark.parametrize("lend", [False, True])
@pytest.mark.parametrize("chunk", [1, 1000, 65536, 1 << 20])
def test_zero_copy_path_with_large_and_small_frames(chunk: int, lend: bool) -> None:
    big = bytes(range(256)) * 4000  # 1,024,000 bytes: gets a buffer of its own
    frames_in = [("/img", big), ("/a", b"x"), ("/img", big[:70_000]), ("", b"")]
    data = b"".join(encode_frame(d, p) for d, p in frames_in)
    out = _receive_into(FrameDecoder(lend_large=lend), data, chunk)
    assert [(f.destination, f.payload) for f in out] == frames_in
    # Larger than the scratch buffer, so received into a buffer of its own (lent or not);
    # the 70 kB one may arrive whole in the scratch buffer and is then copied to bytes.
    assert type(out[0].payload) is (bytearray if lend else bytes)


def test_after_a_large_frame_the_next_read_stops_at_its_header() -> None:
    """After an image, the next read is offered just its header's length, so the next
    image goes straight into a buffer of its own (none of it is copied over from the
    scratch buffer); a small frame there costs one short read, then reads are whole."""
    image = bytes(range(256)) * 3600  # 921,600 bytes
    frame = encode_frame("/camera/image_raw", image)
    header = len(frame) - len(image)
    decoder = FrameDecoder(lend_large=True)
    assert len(decoder.get_buffer()) == FrameDecoder.SCRATCH
    assert [f.payload for f in _receive_into(decoder, frame, 1 << 20)] == [image]
    for _ in range(2):
        target = decoder.get_buffer()
        assert len(target) == header
        target[:] = frame[:header]
        assert decoder.buffer_updated(header) == []
        body = decoder.get_buffer()
        assert len(body) == len(image)  # the whole payload, into its own buffer
        body[:] = image
        (got,) = decoder.buffer_updated(len(image))
        assert got == Frame("/camera/image_raw", image)
    smalls = [("/twist", b"x" * 48), ("/joint_states", b"y" * 100)]
    data = b"".join(encode_frame(d, p) for d, p in smalls)
    assert len(decoder.get_buffer()) == header
    out = _receive_into(decoder, data, 1 << 20)
    assert [(f.destination, f.payload) for f in out] == smalls
    assert len(decoder.get_buffer()) == FrameDecoder.SCRATCH


def test_frames_before_a_bad_prefix_are_still_delivered() -> None:
    decoder = FrameDecoder(max_payload=100)
    data = encode_frame("/ok", b"1") + b"\x01\x00\x00\x00t" + struct.pack("<I", 1000)
    assert decoder.feed(data) == [Frame("/ok", b"1")]
    assert isinstance(decoder.error, FrameTooLargeError)
    with pytest.raises(FrameTooLargeError):
        decoder.feed(b"")


_repeating = st.lists(
    st.one_of(
        # mostly one topic at one size (a burst repeats the whole header), with other
        # topics, other sizes, commands and keepalives in between
        st.tuples(st.just("/cmd_vel"), st.binary(min_size=48, max_size=48)),
        st.tuples(st.just("/cmd_vel"), st.binary(min_size=48, max_size=48)),
        st.tuples(
            st.sampled_from(["/cmd_vel", "/other", "__keepalive_like"]), st.binary(max_size=60)
        ),
        st.just(("", b"")),
    ),
    max_size=40,
)


@given(_repeating, st.lists(st.integers(min_value=1, max_value=200), min_size=1))
def test_repeated_headers_decode_like_any_other_however_cut(
    frames: list[tuple[str, bytes]], cuts: list[int]
) -> None:
    """Frames repeating the last frame's whole header (read with one comparison) come out
    as every other frame does, whatever the read boundaries, through both entry points."""
    data = b"".join(encode_frame(d, p) for d, p in frames)
    for via_buffer in (False, True):
        decoder = FrameDecoder()
        out: list[Frame] = []
        pos = i = 0
        while pos < len(data):
            step = cuts[i % len(cuts)]
            if via_buffer:
                target = decoder.get_buffer()
                n = min(len(target), step, len(data) - pos)
                target[:n] = data[pos : pos + n]
                target.release()
                out += decoder.buffer_updated(n)
            else:
                n = step
                out += decoder.feed(data[pos : pos + n])
            pos += n
            i += 1
        assert [(f.destination, f.payload) for f in out] == frames


@given(_repeating, st.lists(st.integers(min_value=1, max_value=200), min_size=1))
def test_repeated_messages_shortcut_agrees_with_buffer_updated_however_cut(
    frames: list[tuple[str, bytes]], cuts: list[int]
) -> None:
    """`repeated_messages(n)` either returns what `buffer_updated(n)` would (plain topic
    messages on one destination) and leaves the decoder in the same state, or consumes
    nothing."""
    data = b"".join(encode_frame(d, p) for d, p in frames)
    fast, plain = FrameDecoder(), FrameDecoder()
    out: list[Frame] = []
    pos = i = 0
    while pos < len(data):
        chunk = data[pos : pos + cuts[i % len(cuts)]]
        targets = fast.get_buffer(), plain.get_buffer()
        assert len(targets[0]) == len(targets[1])
        n = min(len(targets[0]), len(chunk))
        for target in targets:
            target[:n] = chunk[:n]
            target.release()
        expected = plain.buffer_updated(n)
        run = fast.repeated_messages(n)
        if run is None:
            got = fast.buffer_updated(n)
        else:
            got = [Frame(run[0], payload) for payload in run[1]]
            assert expected
            assert not any(frame.is_command for frame in expected)
            assert all(frame.destination == run[0] for frame in expected)
            assert all(type(payload) is bytes for payload in run[1])
        assert got == expected
        assert (fast.buffered, fast.partial) == (plain.buffered, plain.partial)
        out += got
        pos += n
        i += 1
    assert [(f.destination, f.payload) for f in out] == frames


def test_repeated_messages_refused_for_commands_keepalives_and_partial_reads() -> None:
    decoder = FrameDecoder()
    for frame in (encode_frame("__x", b"{}"), KEEPALIVE):
        assert len(decoder.feed(frame)) == 1
        target = decoder.get_buffer()
        target[: len(frame)] = frame
        target.release()
        assert decoder.repeated_messages(len(frame)) is None  # a command or keepalive
        assert len(decoder.buffer_updated(len(frame))) == 1
    ping = encode_frame("/a", b"ping")
    decoder.feed(ping)
    twin = FrameDecoder()  # less than one whole frame
    twin.feed(ping)
    target = twin.get_buffer()
    target[: len(ping) - 1] = ping[:-1]
    target.release()
    assert twin.repeated_messages(len(ping) - 1) is None
    assert twin.buffered == 0
    twin = FrameDecoder()  # one frame and the first byte of the next: that byte waits
    twin.feed(ping)
    target = twin.get_buffer()
    target[: len(ping) + 1] = ping + ping[:1]
    target.release()
    assert twin.repeated_messages(len(ping) + 1) == ("/a", [b"ping"])
    assert twin.buffered == 1
    assert twin.partial
    target = decoder.get_buffer()
    target[: len(ping)] = ping
    target.release()
    assert decoder.repeated_messages(len(ping)) == ("/a", [b"ping"])
    assert decoder.buffered == 0
    assert not decoder.partial


def test_a_repeated_header_after_a_large_frame_or_a_bad_one_is_still_checked() -> None:
    """The repeated-header shortcut only stands for small frames that passed every check:
    a frame whose header repeats an image's is parsed in full, and a stream broken by a
    bad frame stays broken."""
    image = bytes(FrameDecoder.LARGE)
    decoder = FrameDecoder()
    data = encode_frame("/img", image) * 2 + encode_frame("/a", b"x") * 3
    out = decoder.feed(data)
    assert [(f.destination, len(f.payload)) for f in out] == [("/img", len(image))] * 2 + [
        ("/a", 1)
    ] * 3
    small = FrameDecoder(max_payload=10)
    assert [f.payload for f in small.feed(encode_frame("/a", b"12345") * 2)] == [b"12345"] * 2
    with pytest.raises(FrameTooLargeError):
        small.feed(encode_frame("/a", b"x" * 11))
