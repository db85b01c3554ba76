"""TCPROS, ROS 1's topic transport, without I/O: connection headers and message framing.

A connection starts with one header each way: a little-endian uint32 length, then
fields, each a uint32 length and `name=value` bytes. After that every message is a
uint32 length and its serialized bytes. `TcprosDecoder` takes bytes as they arrive
and hands back the header, then whole messages; anything malformed raises
`TcprosError` naming what was wrong, never anything else.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping

from simbridge.errors import ProtocolError

__all__ = [
    "MAX_HEADER_SIZE",
    "TcprosDecoder",
    "TcprosError",
    "decode_header",
    "encode_header",
    "frame",
]

MAX_HEADER_SIZE = 1 << 20
"""Largest connection header accepted (message definitions are at most a few KiB)."""

_U32 = struct.Struct("<I")


class TcprosError(ProtocolError):
    """Bytes on a TCPROS connection break the protocol."""


def encode_header(fields: Mapping[str, str]) -> bytes:
    """The length-prefixed connection header holding `fields` (names must not contain '=').

    Fields go in name order, as rospy writes them, so headers are byte-identical to its own.
    """
    parts = []
    for name, value in sorted(fields.items()):
        if not name or "=" in name:
            raise TcprosError(f"header field name {name[:80]!r} must be non-empty without '='")
        entry = f"{name}={value}".encode()
        parts.append(_U32.pack(len(entry)) + entry)
    body = b"".join(parts)
    return _U32.pack(len(body)) + body


def decode_header(body: bytes | bytearray | memoryview) -> dict[str, str]:
    """The fields of a header body (without its own length prefix).

    Raises TcprosError for a field that overruns the body, lacks '=' or is not UTF-8.
    """
    view = memoryview(body)
    fields: dict[str, str] = {}
    offset = 0
    end = len(view)
    while offset < end:
        if end - offset < 4:
            raise TcprosError(
                f"header field length at byte {offset} is cut short ({end - offset} of 4 bytes)"
            )
        (size,) = _U32.unpack_from(view, offset)
        offset += 4
        if size > end - offset:
            raise TcprosError(
                f"header field at byte {offset - 4} claims {size} bytes, "
                f"only {end - offset} remain in the header"
            )
        raw = bytes(view[offset : offset + size])
        offset += size
        name, sep, value = raw.partition(b"=")
        if not sep or not name:
            raise TcprosError(f"header field {raw[:80]!r} is not name=value")
        try:
            fields[name.decode()] = value.decode()
        except UnicodeDecodeError as exc:
            raise TcprosError(f"header field {raw[:80]!r} is not UTF-8: {exc}") from exc
    return fields


def frame(payload: bytes) -> bytes:
    """One message as it goes on the wire: its length, then its bytes."""
    return _U32.pack(len(payload)) + payload


class TcprosDecoder:
    """Incremental parser of one connection's bytes: the header first, then messages.

    Each chunk is parsed where it lies; a frame cut by a chunk's end is kept as the
    pieces that arrived (views of their chunks, not copies) and joined once when its
    last byte comes, so a camera image read in 256 KiB chunks costs one copy instead of
    a buffer grown and copied chunk by chunk.
    """

    __slots__ = ("_have", "_head", "_max_message", "_need", "_parts", "header")

    def __init__(self, max_message: int) -> None:
        self._max_message = max_message
        self._head = b""
        """Fewer than 4 bytes of a length prefix, waiting for the rest."""
        self._parts: list[bytes | memoryview] = []
        """The body received so far of the frame whose length prefix came last."""
        self._have = 0
        self._need = 0
        """Body bytes of that frame: `_have` of `_need` received."""
        self.header: dict[str, str] | None = None
        """The peer's header once it has arrived."""

    def feed(self, data: bytes | bytearray | memoryview) -> list[bytes]:
        """Take `data`; return the messages it completed (the header is stored in `header`).

        Raises TcprosError when a length is over its limit or the header is malformed.
        """
        source = data if type(data) is bytes else bytes(data)
        if not self._head and not self._parts and self.header is not None:
            # The commonest read: exactly one whole message (a lone one, a reply).
            available = len(source)
            if available >= 4 and _U32.unpack_from(source)[0] == available - 4:
                if available - 4 > self._max_message:
                    raise self._too_big(available - 4)
                return [source[4:]]
        messages: list[bytes] = []
        offset = 0
        if self._head:
            source = self._head + source
            self._head = b""
        elif self._parts:
            cut = self._need - self._have
            if len(source) < cut:
                self._parts.append(source)
                self._have += len(source)
                return messages
            parts = self._parts
            parts.append(memoryview(source)[:cut] if cut < len(source) else source)
            self._parts, self._have, self._need = [], 0, 0
            self._complete(b"".join(parts), messages)
            offset = cut
        available = len(source)
        unpack = _U32.unpack_from
        view = memoryview(source)
        limit = MAX_HEADER_SIZE if self.header is None else self._max_message
        while available - offset >= 4:
            (size,) = unpack(source, offset)
            if size > limit:
                raise self._too_big(size)
            start = offset + 4
            if available - start < size:
                self._parts = [view[start:]]
                self._have, self._need = available - start, size
                return messages
            offset = start + size
            if self.header is None:
                self.header = decode_header(view[start:offset])
                limit = self._max_message
            else:
                messages.append(source[start:offset])
        if offset < available:
            self._head = source[offset:]
        return messages

    def _too_big(self, size: int) -> TcprosError:
        """The error for a length over its limit (raised before anything is buffered)."""
        if self.header is None:
            return TcprosError(
                f"connection header of {size} bytes is over the limit of {MAX_HEADER_SIZE} bytes"
            )
        return TcprosError(
            f"message of {size} bytes is over the limit of {self._max_message} bytes"
        )

    def _complete(self, body: bytes, messages: list[bytes]) -> None:
        if self.header is None:
            self.header = decode_header(body)
        else:
            messages.append(body)

    @property
    def pending(self) -> int:
        """Bytes received but not yet part of a complete frame."""
        return len(self._head) + (self._have + 4 if self._parts else 0)
