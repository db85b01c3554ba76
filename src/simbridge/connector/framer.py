"""Outgoing frames for one protocol mode.

ROS1 frames are what `simbridge.protocol` builds. In ROS2 mode Unity writes every name
and every JSON payload with a trailing NUL counted in its length, so this does too.
"""

from __future__ import annotations

import json
import struct
from typing import Literal

from simbridge.protocol import Command, ServiceRequestHeader, ServiceResponseHeader

__all__ = ["Framer"]

_pack_u32 = struct.Struct("<I").pack


class Framer:
    """Builds frames; caches each destination's length-prefixed name."""

    __slots__ = ("_nul", "_prefixes")

    def __init__(self, protocol: Literal["ROS1", "ROS2"]) -> None:
        self._nul = b"\x00" if protocol == "ROS2" else b""
        self._prefixes: dict[str, bytes] = {}

    def prefix(self, destination: str) -> bytes:
        """`uint32 len` + name: everything of a frame before its payload length."""
        cached = self._prefixes.get(destination)
        if cached is None:
            name = destination.encode() + self._nul
            cached = self._prefixes[destination] = _pack_u32(len(name)) + name
        return cached

    def message(self, destination: str, payload: bytes) -> bytes:
        """One complete message frame."""
        return b"".join((self.prefix(destination), _pack_u32(len(payload)), payload))

    def command(self, command: Command) -> bytes:
        """One system-command frame."""
        if not self._nul:
            return command.encode()
        return self.message(command.NAME, json.dumps(command.to_json()).encode() + self._nul)

    def service_request(self, srv_id: int, service: str, payload: bytes) -> bytes:
        """`__request` header and request frame, back to back."""
        return self.command(ServiceRequestHeader(srv_id)) + self.message(service, payload)

    def service_response(self, srv_id: int, service: str, payload: bytes) -> bytes:
        """`__response` header and response frame, back to back."""
        return self.command(ServiceResponseHeader(srv_id)) + self.message(service, payload)
