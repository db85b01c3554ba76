"""Precompiled serializers for the messages a simulator publishes every few steps.

`JointStateWriter`, `TFWriter` and `ClockWriter` lay a message out once (names, frame
ids, CDR alignment) in a reused buffer and then only write the stamp and the numbers
into it, so publishing costs a few `pack_into` calls instead of building message
objects and walking them field by field. Their bytes equal the generic `Codec`'s for
the same message, in ROS 1 binary and in CDR with the layouts of either generation
(Header with `seq`, left 0, in ROS 1 layouts; without it in ROS 2 layouts).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

from .codec import WireFormat

__all__ = ["ClockWriter", "JointStateWriter", "TFWriter"]

_CDR_LE = b"\x00\x01\x00\x00"
_U32 = struct.Struct("<I")
_POSE = struct.Struct("<7d")


class _Layout:
    """Appends fields to a buffer the way ROS 1 binary or CDR lays them out."""

    def __init__(self, fmt: WireFormat) -> None:
        self.cdr = fmt == "cdr"
        self.buf = bytearray(_CDR_LE if self.cdr else b"")
        self.base = len(self.buf)
        """Where CDR alignment counts from (after the encapsulation header)."""

    def align(self, size: int) -> None:
        if self.cdr:
            self.buf += bytes(-(len(self.buf) - self.base) % size)

    def reserve(self, size: int, align: int) -> int:
        """Room for `size` bytes written later; returns its offset (an empty array is
        not aligned, as rosbags writes it)."""
        if size:
            self.align(align)
        offset = len(self.buf)
        self.buf += bytes(size)
        return offset

    def u32(self, value: int) -> None:
        self.align(4)
        self.buf += _U32.pack(value)

    def string(self, text: str) -> None:
        data = text.encode()
        if self.cdr:
            self.u32(len(data) + 1)
            self.buf += data + b"\x00"
        else:
            self.u32(len(data))
            self.buf += data

    def header(self, frame_id: str, seq: bool) -> int:
        """A std_msgs/Header; returns the offset of its stamp."""
        if seq:
            self.u32(0)
        stamp = self.reserve(8, 4)
        self.string(frame_id)
        return stamp


def _stamp_struct(fmt: WireFormat) -> struct.Struct:
    """ROS 1 `time` is uint32 secs; builtin_interfaces/Time in CDR has int32 sec."""
    return struct.Struct("<iI" if fmt == "cdr" else "<II")


class JointStateWriter:
    """sensor_msgs/JointState for a fixed list of joint names."""

    def __init__(
        self, fmt: WireFormat, names: Sequence[str], frame_id: str = "", seq: bool = True
    ) -> None:
        """`seq`: the Header has ROS 1's seq field (the registry's layouts say)."""
        self.wire = (fmt, seq)
        self.names = list(names)
        out = _Layout(fmt)
        self._stamp_at = out.header(frame_id, seq)
        out.u32(len(names))
        for name in names:
            out.string(name)
        self._arrays: list[int] = []
        for _ in range(3):
            out.u32(len(names))
            self._arrays.append(out.reserve(8 * len(names), 8))
        self._buf = out.buf
        self._stamp = _stamp_struct(fmt)
        self._values = struct.Struct(f"<{len(names)}d")
        self.size = len(names)

    def encode(
        self,
        sec: int,
        nanosec: int,
        position: Sequence[float],
        velocity: Sequence[float],
        effort: Sequence[float],
    ) -> bytes:
        """The payload for this stamp and these values (one per name, in order)."""
        buf, pack = self._buf, self._values.pack_into
        self._stamp.pack_into(buf, self._stamp_at, sec, nanosec)
        at = self._arrays
        pack(buf, at[0], *position)
        pack(buf, at[1], *velocity)
        pack(buf, at[2], *effort)
        return bytes(buf)


class TFWriter:
    """tf2_msgs/TFMessage for a fixed list of (parent, child) frames, one stamp for all."""

    def __init__(
        self, fmt: WireFormat, frames: Sequence[tuple[str, str]], seq: bool = True
    ) -> None:
        self.wire = (fmt, seq)
        self.frames = tuple(frames)
        out = _Layout(fmt)
        out.u32(len(frames))
        self._stamps: list[int] = []
        self._poses: list[int] = []
        for parent, child in frames:
            self._stamps.append(out.header(parent, seq))
            out.string(child)
            self._poses.append(out.reserve(56, 8))
        self._buf = out.buf
        self._stamp = _stamp_struct(fmt)

    def encode(self, sec: int, nanosec: int, poses: Sequence[Sequence[float]]) -> bytes:
        """The payload; `poses[i]` is (x, y, z, qx, qy, qz, qw) of `frames[i]`."""
        buf = self._buf
        stamp, pose = self._stamp.pack_into, _POSE.pack_into
        for at in self._stamps:
            stamp(buf, at, sec, nanosec)
        for at, values in zip(self._poses, poses, strict=True):
            pose(buf, at, *values)
        return bytes(buf)


class ClockWriter:
    """rosgraph_msgs/Clock."""

    def __init__(self, fmt: WireFormat) -> None:
        self.fmt = fmt
        out = _Layout(fmt)
        self._at = out.reserve(8, 4)
        self._buf = out.buf
        self._stamp = _stamp_struct(fmt)

    def encode(self, sec: int, nanosec: int) -> bytes:
        """The payload for this time."""
        self._stamp.pack_into(self._buf, self._at, sec, nanosec)
        return bytes(self._buf)
