"""ROS-TCP framing: `uint32 LE len, destination, uint32 LE len, payload`, sans-I/O."""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import NoReturn

from simbridge.errors import ProtocolError

__all__ = [
    "DEFAULT_MAX_FRAME_SIZE",
    "KEEPALIVE",
    "MAX_DESTINATION_SIZE",
    "Frame",
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


@dataclass(frozen=True, slots=True)
class Frame:
    """One decoded frame; `destination` has trailing NULs (ROS 2 clients) removed."""

    destination: str
    payload: bytes

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


def frame_header(destination: str, payload_size: int) -> bytes:
    """Everything of a frame before its payload (lets writers avoid copying big payloads)."""
    dest = destination.encode()
    return _pack_u32(len(dest)) + dest + _pack_u32(payload_size)


def encode_frame(destination: str, payload: bytes = b"") -> bytes:
    """One complete frame as bytes."""
    dest = destination.encode()
    return b"".join((_pack_u32(len(dest)), dest, _pack_u32(len(payload)), payload))


class FrameDecoder:
    """Incremental frame parser: feed it bytes as they arrive, get whole frames back.

    Raises FrameTooLargeError (before buffering the body) when a length prefix is over
    the bound, and ProtocolError for a destination that is not UTF-8; after either the
    decoder refuses further input, since the byte stream has lost its framing.
    """

    __slots__ = ("_broken", "_buf", "_max_dest", "_max_payload", "_pos")

    def __init__(
        self,
        max_payload: int = DEFAULT_MAX_FRAME_SIZE,
        max_destination: int = MAX_DESTINATION_SIZE,
    ) -> None:
        self._buf = bytearray()
        self._pos = 0
        self._max_payload = max_payload
        self._max_dest = max_destination
        self._broken: ProtocolError | None = None

    @property
    def buffered(self) -> int:
        """Bytes received but not yet returned as frames."""
        return len(self._buf) - self._pos

    def feed(self, data: bytes) -> list[Frame]:
        """Add received bytes; return every frame they complete, in order."""
        if self._broken is not None:
            raise self._broken
        buf = self._buf
        if self._pos:
            del buf[: self._pos]
            self._pos = 0
        buf += data
        frames: list[Frame] = []
        pos = 0
        end = len(buf)
        while end - pos >= 4:
            dlen = _unpack_u32(buf, pos)[0]
            if dlen > self._max_dest:
                self._fail(
                    FrameTooLargeError(
                        f"destination length {dlen} exceeds the limit of {self._max_dest} bytes"
                    )
                )
            if end - pos < 8 + dlen:
                break
            plen = _unpack_u32(buf, pos + 4 + dlen)[0]
            if plen > self._max_payload:
                self._fail(
                    FrameTooLargeError(
                        f"payload length {plen} bytes exceeds the limit of "
                        f"{self._max_payload} bytes (--max-frame-mb)"
                    )
                )
            stop = pos + 8 + dlen + plen
            if stop > end:
                break
            raw_dest = bytes(buf[pos + 4 : pos + 4 + dlen])
            try:
                dest = raw_dest.decode().rstrip("\x00")
            except UnicodeDecodeError:
                self._fail(ProtocolError(f"destination {raw_dest[:60]!r} is not valid UTF-8"))
            frames.append(Frame(dest, bytes(buf[pos + 8 + dlen : stop])))
            pos = stop
        self._pos = pos
        return frames

    def _fail(self, error: ProtocolError) -> NoReturn:
        self._broken = error
        raise error
