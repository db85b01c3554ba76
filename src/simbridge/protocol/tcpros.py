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
    """Incremental parser of one connection's bytes: the header first, then messages."""

    __slots__ = ("_buffer", "_max_message", "header")

    def __init__(self, max_message: int) -> None:
        self._buffer = bytearray()
        self._max_message = max_message
        self.header: dict[str, str] | None = None
        """The peer's header once it has arrived."""

    def feed(self, data: bytes | bytearray | memoryview) -> list[bytes]:
        """Take `data`; return the messages it completed (the header is stored in `header`).

        Raises TcprosError when a length is over its limit or the header is malformed.
        """
        buffer = self._buffer
        if buffer:
            buffer += data
            source: bytes | bytearray = buffer
        else:
            source = bytes(data)  # common case: parse the chunk as it came, no buffer copy
        messages: list[bytes] = []
        offset = 0
        available = len(source)
        unpack = _U32.unpack_from
        limit = self._max_message
        with memoryview(source) as view:  # released before the buffer is resized
            while available - offset >= 4:
                (size,) = unpack(source, offset)
                if self.header is None:
                    if size > MAX_HEADER_SIZE:
                        raise TcprosError(
                            f"connection header of {size} bytes is over the limit of "
                            f"{MAX_HEADER_SIZE} bytes"
                        )
                elif size > limit:
                    raise TcprosError(
                        f"message of {size} bytes is over the limit of {limit} bytes"
                    )
                start = offset + 4
                if available - start < size:
                    break
                offset = start + size
                if self.header is None:
                    self.header = decode_header(bytes(view[start:offset]))
                else:
                    messages.append(bytes(view[start:offset]))
        if source is buffer:
            if offset:
                del buffer[:offset]
        elif offset < available:
            buffer += source[offset:]
        return messages

    @property
    def pending(self) -> int:
        """Bytes received but not yet part of a complete frame."""
        return len(self._buffer)
