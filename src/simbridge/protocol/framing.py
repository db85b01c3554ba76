"""ROS-TCP framing: `uint32 LE len, destination, uint32 LE len, payload`, sans-I/O."""

from __future__ import annotations

import struct
import sys
from collections.abc import Callable
from dataclasses import dataclass

from simbridge.errors import ProtocolError

__all__ = [
    "DEFAULT_MAX_FRAME_SIZE",
    "KEEPALIVE",
    "MAX_DESTINATION_SIZE",
    "Frame",
    "FrameBudgetError",
    "FrameDecoder",
    "FrameTooLargeError",
    "encode_frame",
    "frame_header",
]

_U32 = struct.Struct("<I")
_pack_u32 = _U32.pack
_unpack_u32 = _U32.unpack_from

DEFAULT_MAX_FRAME_SIZE = 64 * 1024 * 1024
"""Largest payload accepted by default (64 MiB); larger prefixes are refused unread."""

MAX_DESTINATION_SIZE = 64 * 1024
"""Largest destination (topic or command) name accepted, in bytes."""

KEEPALIVE = b"\x00" * 8
"""An empty destination with an empty payload: the keepalive frame."""


@dataclass(slots=True)
class Frame:
    """One decoded frame; `destination` has trailing NULs (ROS 2 clients) removed.

    `payload` is `bytes`, or from a decoder made with `lend_large`, for a large payload
    (`FrameDecoder.LARGE` or more), the bytearray it was received into: handed over, never
    reused or written by the decoder again, so a large image is not copied once more.
    Not frozen: one is built per received frame, and frozen dataclasses are slower to build.
    """

    destination: str
    payload: bytes | bytearray

    @property
    def is_keepalive(self) -> bool:
        """True for the empty keepalive frame."""
        return not self.destination and not self.payload

    @property
    def is_command(self) -> bool:
        """True when the destination names a system command (`__...`)."""
        return self.destination.startswith("__")


class FrameTooLargeError(ProtocolError):
    """A length prefix exceeds the configured bound; the stream cannot be resynchronised."""


class FrameBudgetError(ProtocolError):
    """A large frame's buffer could not grow: the memory budget refused it."""


def _always(_: int) -> bool:
    return True


def _ignore(_: int) -> None:
    return None


def frame_header(destination: str, payload_size: int) -> bytes:
    """Everything of a frame before its payload (lets writers avoid copying big payloads)."""
    dest = destination.encode()
    return _pack_u32(len(dest)) + dest + _pack_u32(payload_size)


def encode_frame(destination: str, payload: bytes = b"") -> bytes:
    """One complete frame as bytes."""
    dest = destination.encode()
    return b"".join((_pack_u32(len(dest)), dest, _pack_u32(len(payload)), payload))


class FrameDecoder:
    """Incremental frame parser: give it bytes as they arrive, get whole frames back.

    Two ways in: `feed(data)`, or the zero-copy pair `get_buffer()` / `buffer_updated(n)`
    (asyncio.BufferedProtocol style) where the socket reads straight into the decoder's
    memory. A large payload is read into a buffer of exactly its size. With `lend_large`
    that buffer becomes the frame's payload (no copy; it leaves the decoder's budget and a
    new one is allocated for the next large frame, unless the receiver gives it back with
    `recycle` or holds no reference to it by then); else the payload is copied to bytes and
    the buffer reused.

    After a large frame, `get_buffer` offers only that frame's header length (an image
    stream's next frame has the same header), so the next image's bytes go straight into
    its own buffer instead of filling the scratch buffer to be copied over (up to 256 KiB
    of every image before); a small frame there costs one more, short, read.

    A length prefix over the bound (FrameTooLargeError, raised before the body is
    buffered) or a destination that is not UTF-8 (ProtocolError) breaks the stream:
    `error` is set, frames completed before it are still returned, and every later call
    raises it. A call that completed no frame raises at once.
    """

    __slots__ = (
        "_big",
        "_big_dest",
        "_big_filled",
        "_big_size",
        "_broken",
        "_buf",
        "_dests",
        "_end",
        "_header_hint",
        "_lend",
        "_lent",
        "_max_command",
        "_max_dest",
        "_max_payload",
        "_release",
        "_reserve",
        "_run_dest",
        "_run_head",
        "_run_size",
        "_spare",
        "_start",
    )

    SCRATCH = 256 * 1024
    """Size of the buffer small frames are parsed from."""
    LARGE = 64 * 1024
    """Payloads at least this big get a buffer of their own."""
    FIRST_CHUNK = 4 * 1024 * 1024
    """Largest buffer allocated for a payload before its bytes arrive."""

    def __init__(
        self,
        max_payload: int = DEFAULT_MAX_FRAME_SIZE,
        max_destination: int = MAX_DESTINATION_SIZE,
        *,
        max_command: int | None = None,
        reserve: Callable[[int], bool] = _always,
        release: Callable[[int], None] = _ignore,
        lend_large: bool = False,
    ) -> None:
        self._buf = bytearray(self.SCRATCH)
        self._start = 0
        self._end = 0
        self._big: bytearray | None = None
        self._big_dest = ""
        self._big_filled = 0
        self._big_size = 0
        self._spare: bytearray | None = None
        self._lent: bytearray | None = None
        """The last payload lent, reused for the next one of its size if nobody holds it."""
        self._header_hint = 0
        """Header length of the last large frame while no small frame has followed it."""
        self._lend = lend_large
        self._max_payload = max_payload
        self._max_command = max_payload if max_command is None else max_command
        self._reserve = reserve
        self._release = release
        self._max_dest = max_destination
        self._broken: ProtocolError | None = None
        self._dests: dict[bytes, str] = {}
        self._run_head = b"\x00"
        """The whole header (destination and payload length) of the last small frame: a
        stream of one topic's messages of one size (a command each step, the pings of a
        round trip) repeats it, and one comparison then stands for parsing it (the
        limits it passed are the same)."""
        self._run_size = 0
        """Bytes of such a frame (header and payload); 0 until there is one."""
        self._run_dest = ""

    @property
    def error(self) -> ProtocolError | None:
        """Why the stream is unusable, once it is."""
        return self._broken

    @property
    def buffered(self) -> int:
        """Bytes received but not yet returned as frames."""
        return self._end - self._start + self._big_filled

    @property
    def partial(self) -> bool:
        """Whether part of a frame has arrived and the rest has not."""
        return self._big is not None or self._end > self._start

    def get_buffer(self) -> memoryview:
        """Writable memory for the next received bytes (never empty)."""
        big = self._big
        if big is not None:
            if self._big_filled == len(big):
                self._grow(big)
            if self._broken is not None:
                return memoryview(self._buf)
            return memoryview(big)[self._big_filled : self._big_size]
        if self._end == len(self._buf):
            pending = self._end - self._start
            if pending * 2 > len(self._buf):
                self._buf.extend(bytes(len(self._buf)))
            self._buf[:pending] = self._buf[self._start : self._end]
            self._start, self._end = 0, pending
        if self._header_hint and self._end == self._start:
            return memoryview(self._buf)[self._end : self._end + self._header_hint]
        return memoryview(self._buf)[self._end :]

    def buffer_updated(self, nbytes: int) -> list[Frame]:
        """`nbytes` were written into the last `get_buffer()`; return completed frames."""
        if self._broken is not None:
            raise self._broken
        big = self._big
        if big is not None:
            self._big_filled += nbytes
            if self._big_filled < self._big_size:
                return []
            self._big, self._big_filled = None, 0
            if self._lend:
                self._release(len(big))  # handed over: no longer the decoder's to account for
                self._lent = big if len(big) <= self.FIRST_CHUNK else None
                return [Frame(self._big_dest, big)]
            with memoryview(big) as view:
                frame = Frame(self._big_dest, bytes(view[: self._big_size]))
            if len(big) <= self.FIRST_CHUNK:
                self._spare = big  # the next large frame reuses it (still reserved)
            else:
                self._release(len(big))
            return [frame]
        self._end += nbytes
        frames = self._parse()
        if self._broken is not None and not frames:
            raise self._broken
        return frames

    def repeated_messages(self, nbytes: int) -> tuple[str, list[bytes]] | None:
        """`buffer_updated(nbytes)` for the commonest reads: one or more small topic
        messages (not commands or keepalives) that all repeat the whole header of the
        frame before them (a command each step, each ping of a round trip, a burst on one
        topic), ending on a frame boundary or inside one more such message: their
        destination and payloads, the decoder left as `buffer_updated` leaves it (that
        message's start kept for the next read). None for any other read, with nothing
        consumed or changed: call `buffer_updated(nbytes)` then."""
        size = self._run_size
        if not size or self._big is not None or self._broken is not None:
            return None
        start, end = self._start, self._end + nbytes
        count = (end - start) // size
        dest = self._run_dest
        if not count or not dest or dest.startswith("__"):
            return None
        buf, head = self._buf, self._run_head
        stop = start + count * size
        rest = end - stop
        # what is left is the start of one more message like them (the general path would
        # leave it too): the header so far, or the whole header and part of the payload
        if rest and not (
            buf.startswith(head, stop) if rest >= len(head) else head.startswith(buf[stop:end])
        ):
            return None
        skip = len(head)
        if count == 1:  # the commonest read (a round trip's ping): no loop, no view
            if not buf.startswith(head, start):
                return None
            payloads = [bytes(buf[start + skip : stop])]
        else:
            startswith = buf.startswith
            for pos in range(start, stop, size):
                if not startswith(head, pos):
                    return None
            with memoryview(buf) as view:
                payloads = [bytes(view[p + skip : p + size]) for p in range(start, stop, size)]
        if rest:
            self._start, self._end = stop, end
        else:
            self._start = self._end = 0
        self._header_hint = 0
        return dest, payloads

    def feed(self, data: bytes | bytearray | memoryview) -> list[Frame]:
        """Add received bytes; return every frame they complete, in order."""
        if self._broken is not None:
            raise self._broken
        frames: list[Frame] = []
        view = memoryview(data)
        while view and self._broken is None:
            target = self.get_buffer()
            n = min(len(target), len(view))
            target[:n] = view[:n]
            target.release()
            frames += self.buffer_updated(n)
            view = view[n:]
        if self._broken is not None and not frames:
            raise self._broken
        return frames

    def _grow(self, big: bytearray) -> None:
        """Double a large frame's buffer (up to its declared size) as its bytes arrive."""
        extra = min(self._big_size, 2 * len(big)) - len(big)
        if not self._reserve(extra):
            self._broken = FrameBudgetError(
                f"the endpoint's memory budget is exhausted: cannot buffer {extra:,} more "
                f"bytes of a {self._big_size:,}-byte frame for {self._big_dest[:80]!r}"
            )
            return
        _extend_zeros(big, extra)

    def _large_buffer(self, plen: int, have: int) -> bytearray | None:
        """A buffer for a large payload: the spare one from the last large frame when big
        enough (no allocation, no page faults), else a new one; None if refused. (A
        lending decoder's buffers are exactly their payload's size, so its spare, one
        given back by `recycle`, fits only a payload of its very size.)"""
        size = max(min(plen, self.FIRST_CHUNK), have)
        spare, self._spare = self._spare, None
        lent, self._lent = self._lent, None
        if spare is None and lent is not None and len(lent) == plen and sys.getrefcount(lent) == 2:
            # Its receiver let go of it (CPython counts every reference, views included):
            # the decoder's again, as if given back with `recycle`.
            return lent if self._reserve(plen) else None
        if spare is not None:
            if len(spare) == plen if self._lend else len(spare) >= size:
                return spare
            self._release(len(spare))
        if not self._reserve(size):
            return None
        return bytearray(size)

    def recycle(self, buffer: bytearray) -> None:
        """Take back a lent payload its receiver is done with (it keeps no reference or
        view): the next large frame of the same size is received into it, saving the
        allocation and zero-fill of a new buffer (an image stream's frames are one size).
        Kept only when no other is, up to FIRST_CHUNK bytes, and within the budget."""
        size = len(buffer)
        if self._lend and self._spare is None and size <= self.FIRST_CHUNK and self._reserve(size):
            self._spare = buffer

    def waiting_large(self) -> tuple[str, bytearray] | None:
        """(destination, buffer) of a large topic message whose header is parsed and none
        of whose payload has arrived yet, `buffer` reserved for exactly that payload: a
        caller may move the payload elsewhere (straight from the socket, or into `buffer`
        itself) and then call `skip_large`. None otherwise (commands included)."""
        big = self._big
        if big is None or self._big_filled or self._broken is not None:
            return None
        dest = self._big_dest
        if not dest or dest.startswith("__") or len(big) != self._big_size:
            return None
        return dest, big

    def skip_large(self, *, taken: bool = False) -> None:
        """The payload `waiting_large` named was taken from the stream elsewhere: expect
        the next frame. Its buffer is kept for the next large payload, or with `taken`
        handed over with the payload (it leaves the budget, as a lent one does)."""
        waiting = self.waiting_large()
        if waiting is None:
            raise ValueError("no large payload is waiting untouched")
        big = waiting[1]
        self._big = None
        if not taken and self._spare is None and len(big) <= self.FIRST_CHUNK:
            self._spare = big
        else:
            self._release(len(big))

    def discard(self) -> None:
        """Drop a partly received large frame and hand its memory back (connection closed)."""
        for buf in (self._big, self._spare):
            if buf is not None:
                self._release(len(buf))
        self._big = self._spare = self._lent = None
        self._big_filled = 0

    def _parse(self) -> list[Frame]:
        buf = self._buf
        frames: list[Frame] = []
        pos, end = self._start, self._end
        run_head, run_size, run_dest = self._run_head, self._run_size, self._run_dest
        with memoryview(buf) as view:
            while end - pos >= 4:
                if run_size and end - pos >= run_size and buf.startswith(run_head, pos):
                    frames.append(
                        Frame(run_dest, bytes(view[pos + len(run_head) : pos + run_size]))
                    )
                    pos += run_size
                    continue
                dlen = _unpack_u32(buf, pos)[0]
                if dlen > self._max_dest:
                    self._broken = FrameTooLargeError(
                        f"destination length {dlen} exceeds the limit of {self._max_dest} bytes"
                    )
                    break
                if end - pos < 8 + dlen:
                    break
                plen = _unpack_u32(buf, pos + 4 + dlen)[0]
                if plen > self._max_payload:
                    self._broken = FrameTooLargeError(
                        f"payload length {plen} bytes exceeds the limit of "
                        f"{self._max_payload} bytes (--max-frame-mb)"
                    )
                    break
                if plen > self._max_command and buf[pos + 4 : pos + 6] == b"__":
                    self._broken = FrameTooLargeError(
                        f"system command payload of {plen} bytes exceeds the limit of "
                        f"{self._max_command} bytes"
                    )
                    break
                body = pos + 8 + dlen
                stop = body + plen
                if stop > end and plen < self.LARGE:
                    break
                raw_dest = bytes(view[pos + 4 : pos + 4 + dlen])
                dest = self._dests.get(raw_dest)
                if dest is None:
                    try:
                        dest = raw_dest.decode().rstrip("\x00")
                    except UnicodeDecodeError:
                        self._broken = ProtocolError(
                            f"destination {raw_dest[:60]!r} is not valid UTF-8"
                        )
                        break
                    if len(self._dests) < 1024:
                        self._dests[raw_dest] = dest
                if stop > end:
                    big = self._large_buffer(plen, end - body)
                    if big is None:
                        self._broken = FrameBudgetError(
                            f"the endpoint's memory budget is exhausted: cannot buffer a "
                            f"{plen:,}-byte frame for {dest[:80]!r}"
                        )
                        break
                    with memoryview(big) as target:  # a bytearray slice would copy twice
                        target[: end - body] = view[body:end]
                    self._big, self._big_dest, self._big_filled = big, dest, end - body
                    self._big_size = plen
                    self._header_hint = body - pos
                    pos = end
                    break
                frames.append(Frame(dest, bytes(view[body:stop])))
                if plen < self.LARGE:
                    run_head, run_size, run_dest = bytes(view[pos:body]), stop - pos, dest
                pos = stop
        self._run_head, self._run_size, self._run_dest = run_head, run_size, run_dest
        if pos == end:
            self._start = self._end = 0
        else:
            self._start = pos
        if frames and self._big is None:
            self._header_hint = 0
        return frames


_ZEROS = bytes(FrameDecoder.FIRST_CHUNK)


def _extend_zeros(buf: bytearray, n: int) -> None:
    """Append `n` zero bytes without a temporary of size `n` (large reallocs are remaps)."""
    with memoryview(_ZEROS) as zeros:
        while n > 0:
            step = min(n, len(zeros))
            buf.extend(zeros[:step])
            n -= step
