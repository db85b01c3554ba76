"""FrameDecoder memory: a declared length costs nothing until its bytes arrive; a budget
can refuse growth; command payloads have their own cap."""

from __future__ import annotations

import struct

import pytest

from simbridge.errors import ProtocolError
from simbridge.protocol import (
    Frame,
    FrameBudgetError,
    FrameDecoder,
    FrameTooLargeError,
    encode_frame,
)

MIB = 1024 * 1024


class Ledger:
    """Counts what the decoder reserves and releases, refusing beyond `limit`."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.held = 0
        self.peak = 0

    def reserve(self, n: int) -> bool:
        if self.held + n > self.limit:
            return False
        self.held += n
        self.peak = max(self.peak, self.held)
        return True

    def release(self, n: int) -> None:
        self.held -= n


def _header(dest: bytes, size: int) -> bytes:
    return struct.pack("<I", len(dest)) + dest + struct.pack("<I", size)


def _receive(decoder: FrameDecoder, data: bytes) -> list[object]:
    frames: list[object] = []
    view = memoryview(data)
    while view:
        target = decoder.get_buffer()
        n = min(len(target), len(view))
        target[:n] = view[:n]
        target.release()
        frames += decoder.buffer_updated(n)
        view = view[n:]
    return frames


def test_declared_length_is_not_allocated_up_front() -> None:
    ledger = Ledger(10**12)
    decoder = FrameDecoder(64 * MIB, reserve=ledger.reserve, release=ledger.release)
    assert _receive(decoder, _header(b"/big", 64 * MIB) + b"x" * 1000) == []
    assert ledger.held == FrameDecoder.FIRST_CHUNK  # not 64 MiB
    assert decoder.partial
    assert len(decoder.get_buffer()) <= FrameDecoder.FIRST_CHUNK


def test_buffer_grows_with_arrivals_and_is_released_on_completion() -> None:
    ledger = Ledger(10**12)
    decoder = FrameDecoder(64 * MIB, reserve=ledger.reserve, release=ledger.release)
    payload = bytes(range(256)) * (40 * MIB // 256)
    frames = _receive(decoder, encode_frame("/big", payload))
    assert len(frames) == 1
    assert frames[0].payload == payload  # type: ignore[attr-defined]
    assert ledger.held == 0
    assert FrameDecoder.FIRST_CHUNK < ledger.peak <= 2 * len(payload)
    assert not decoder.partial


def test_image_sized_payload_gets_one_exact_buffer() -> None:
    ledger = Ledger(10**12)
    decoder = FrameDecoder(reserve=ledger.reserve, release=ledger.release)
    _receive(decoder, _header(b"/img", 921_641) + b"x")
    assert ledger.held == 921_641


def test_budget_refusal_breaks_the_stream_with_a_clear_error() -> None:
    ledger = Ledger(6 * MIB)
    decoder = FrameDecoder(64 * MIB, reserve=ledger.reserve, release=ledger.release)
    with pytest.raises(FrameBudgetError, match="memory budget is exhausted"):
        _receive(decoder, _header(b"/big", 32 * MIB) + b"x" * (5 * MIB))
    decoder.discard()
    assert ledger.held == 0


def test_first_chunk_refused() -> None:
    ledger = Ledger(MIB)
    decoder = FrameDecoder(64 * MIB, reserve=ledger.reserve, release=ledger.release)
    with pytest.raises(FrameBudgetError, match="33,554,432-byte frame for '/big'"):
        _receive(decoder, _header(b"/big", 32 * MIB) + b"x")


def test_command_payload_cap_applies_to_commands_only() -> None:
    decoder = FrameDecoder(64 * MIB, max_command=1000)
    with pytest.raises(FrameTooLargeError, match="system command payload of 2000 bytes"):
        decoder.feed(_header(b"__publish", 2000))
    other = FrameDecoder(64 * MIB, max_command=1000)
    assert other.feed(encode_frame("/topic", b"x" * 2000))[0].payload == b"x" * 2000
    assert isinstance(FrameTooLargeError("x"), ProtocolError)


def test_large_frames_reuse_one_buffer_and_keep_their_bytes() -> None:
    ledger = Ledger(10**12)
    decoder = FrameDecoder(reserve=ledger.reserve, release=ledger.release)
    payloads = [bytes([i]) * (900_000 + i * 1000) for i in range(5)]
    frames = _receive(decoder, b"".join(encode_frame("/img", p) for p in payloads))
    assert [f.payload for f in frames] == payloads  # type: ignore[attr-defined]
    assert ledger.peak <= 2 * 904_000  # one buffer, grown at most once; not one per frame
    decoder.discard()
    assert ledger.held == 0


def test_large_payloads_are_handed_over_and_never_written_again() -> None:
    """Each large payload is the bytearray it was received into (no copy to bytes): a new
    one per frame, out of the decoder's budget once handed over, and untouched by the
    frames received after it."""
    ledger = Ledger(10**12)
    decoder = FrameDecoder(reserve=ledger.reserve, release=ledger.release, lend_large=True)
    payloads = [bytes([i + 1]) * (900_000 + i * 1000) for i in range(5)]
    frames: list[Frame] = []
    for payload in payloads:  # one call per frame: a reused buffer would show
        got = _receive(decoder, encode_frame("/img", payload))
        assert len(got) == 1
        frames += got  # type: ignore[arg-type]
        assert ledger.held == 0  # handed over: no longer charged to the decoder
    assert [f.payload for f in frames] == payloads
    assert all(type(f.payload) is bytearray for f in frames)
    assert len({id(f.payload) for f in frames}) == len(frames)
    assert ledger.peak <= max(map(len, payloads))  # one payload's buffer at a time
    (small,) = decoder.feed(encode_frame("/twist", b"x" * 48))
    assert type(small.payload) is bytes
    decoder.discard()
    assert ledger.held == 0


def test_a_recycled_payload_receives_the_next_frame_of_its_size() -> None:
    """A lent payload given back is the buffer of the next large frame of that very size
    (charged to the decoder meanwhile); one of another size gets a new buffer, and the
    spare's memory is released."""
    ledger = Ledger(10**12)
    decoder = FrameDecoder(reserve=ledger.reserve, release=ledger.release, lend_large=True)
    (first,) = decoder.feed(encode_frame("/img", b"\x01" * 900_000))
    assert type(first.payload) is bytearray
    decoder.recycle(first.payload)
    assert ledger.held == 900_000  # the decoder's again
    (second,) = decoder.feed(encode_frame("/img", b"\x02" * 900_000))
    assert second.payload is first.payload
    assert second.payload == b"\x02" * 900_000
    assert ledger.held == 0
    assert isinstance(second.payload, bytearray)
    decoder.recycle(second.payload)
    (other,) = decoder.feed(encode_frame("/img", b"\x03" * 800_000))
    assert other.payload is not second.payload
    assert other.payload == b"\x03" * 800_000
    assert ledger.held == 0
    assert ledger.peak <= 900_000 + 800_000
    decoder.recycle(bytearray(FrameDecoder.FIRST_CHUNK + 1))  # too large to keep
    assert ledger.held == 0
    assert isinstance(other.payload, bytearray)
    decoder.recycle(other.payload)
    decoder.discard()
    assert ledger.held == 0


def test_recycle_is_ignored_by_a_decoder_that_does_not_lend() -> None:
    ledger = Ledger(10**12)
    decoder = FrameDecoder(reserve=ledger.reserve, release=ledger.release)
    decoder.recycle(bytearray(900_000))
    assert ledger.held == 0
    (frame,) = decoder.feed(encode_frame("/img", b"\x04" * 900_000))
    assert frame.payload == b"\x04" * 900_000
    assert type(frame.payload) is bytes


def test_recycle_within_the_budget_only() -> None:
    ledger = Ledger(1_000_000)
    decoder = FrameDecoder(reserve=ledger.reserve, release=ledger.release, lend_large=True)
    (frame,) = decoder.feed(encode_frame("/img", b"\x05" * 900_000))
    ledger.held = 500_000  # someone else's share meanwhile
    assert isinstance(frame.payload, bytearray)
    decoder.recycle(frame.payload)
    assert ledger.held == 500_000  # refused: not kept
    ledger.held = 0
    (again,) = decoder.feed(encode_frame("/img", b"\x06" * 900_000))
    assert again.payload is not frame.payload


def test_a_lent_payload_nobody_holds_receives_the_next_frame_of_its_size() -> None:
    """Without `recycle`: a lent payload its receiver still holds (here through a view) is
    left alone and the next image gets a new, zeroed buffer; once nothing holds it, the next
    image of its size is received into it (no allocation, no zero-fill)."""
    ledger = Ledger(10**12)
    decoder = FrameDecoder(reserve=ledger.reserve, release=ledger.release, lend_large=True)
    size = 900_000
    frames = [encode_frame("/img", bytes([n]) * size) for n in (1, 2, 3)]
    header = len(frames[0]) - size

    def next_buffer_starts(frame: bytes) -> bytes:
        """Feed `frame`'s header; the first bytes of the buffer its payload will fill."""
        assert decoder.feed(frame[:header]) == []
        with decoder.get_buffer() as target:
            return bytes(target[:4])

    view = memoryview(decoder.feed(frames[0])[0].payload)
    assert next_buffer_starts(frames[1]) == bytes(4)  # held: a new buffer
    assert decoder.feed(frames[1][header:])[0].payload == bytes([2]) * size
    assert view == bytes([1]) * size  # the held payload is untouched
    view.release()
    assert ledger.held == 0
    assert next_buffer_starts(frames[2]) == bytes([2]) * 4  # let go: received into it
    assert ledger.held == size
    assert decoder.feed(frames[2][header:])[0].payload == bytes([3]) * size
    assert ledger.held == 0


def test_a_large_payload_waiting_untouched_can_be_taken_elsewhere() -> None:
    """`waiting_large` names a large topic payload whose header alone has arrived, with
    the buffer reserved for it; after `skip_large` the decoder reads the next frame, and
    the buffer is kept for the next payload of that size, or leaves the budget when
    `taken` with the payload."""
    ledger = Ledger(10**12)
    decoder = FrameDecoder(reserve=ledger.reserve, release=ledger.release, lend_large=True)
    assert decoder.waiting_large() is None
    assert decoder.feed(_header(b"/img", 900_000)) == []
    waiting = decoder.waiting_large()
    assert waiting is not None
    assert waiting[0] == "/img"
    assert len(waiting[1]) == 900_000
    assert ledger.held == 900_000
    decoder.skip_large()
    assert decoder.waiting_large() is None
    assert not decoder.partial
    assert ledger.held == 900_000  # kept for the next one
    assert decoder.feed(encode_frame("/small", b"abc")) == [Frame("/small", b"abc")]
    assert decoder.feed(_header(b"/img", 900_000)) == []
    again = decoder.waiting_large()
    assert again is not None
    assert again[1] is waiting[1]  # the kept buffer
    decoder.skip_large(taken=True)
    assert ledger.held == 0
    (frame,) = decoder.feed(encode_frame("/img", b"\x07" * 900_000))
    assert frame.payload == b"\x07" * 900_000
    assert frame.payload is not waiting[1]


@pytest.mark.parametrize(
    "data",
    [
        encode_frame("/small", b"x" * 100),  # small: never waiting
        _header(b"__publish", 70_000),  # a command is never moved elsewhere
        _header(b"", 70_000),
        _header(b"/img", 900_000) + b"\x01",  # some of its payload has arrived
    ],
)
def test_nothing_else_is_a_waiting_large_payload(data: bytes) -> None:
    decoder = FrameDecoder(max_command=10**6, lend_large=True)
    decoder.feed(data)
    assert decoder.waiting_large() is None
    with pytest.raises(ValueError, match="no large payload"):
        decoder.skip_large()
