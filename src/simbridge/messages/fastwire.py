"""Precompiled serializers for the messages a simulator publishes every few steps.

`JointStateWriter`, `TFWriter`, `ClockWriter` and, for sensors, `ImuWriter`,
`LaserScanWriter` and `OdometryWriter` lay a message out once (names, frame
ids, CDR alignment) in a reused buffer and then only write the stamp and the numbers
into it, so publishing costs a few `pack_into` calls instead of building message
objects and walking them field by field. Their bytes equal the generic `Codec`'s for
the same message, in ROS 1 binary and in CDR with the layouts of either generation
(Header with `seq`, left 0, in ROS 1 layouts; without it in ROS 2 layouts).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from .codec import WireFormat

__all__ = [
    "ClockWriter",
    "ImuWriter",
    "JointStateWriter",
    "LaserScanWriter",
    "OdometryWriter",
    "TFWriter",
]

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


def _doubles(buf: bytearray, offset: int, count: int) -> NDArray[np.float64]:
    """`count` little-endian float64 at `offset` of `buf`, as a writable view (the buffer
    must not be resized while a view exists, and the layout is final by then)."""
    if count == 0:
        return np.zeros(0, "<f8")
    return np.frombuffer(buf, "<f8", count, offset)


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
        self.position, self.velocity, self.effort = (
            _doubles(self._buf, at, self.size) for at in self._arrays
        )
        """The three arrays as float64 views into the buffer: write them in place (e.g.
        `numpy.take(data.qpos, index, out=writer.position)`), then call `finish`."""

    def finish(self, sec: int, nanosec: int) -> bytes:
        """The payload with this stamp and the values now in the views."""
        self._stamp.pack_into(self._buf, self._stamp_at, sec, nanosec)
        return bytes(self._buf)

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


def _floats(buf: bytearray, offset: int, count: int) -> NDArray[np.float32]:
    """`count` little-endian float32 at `offset` of `buf`, as a writable view."""
    if count == 0:
        return np.zeros(0, "<f4")
    return np.frombuffer(buf, "<f4", count, offset)


class _Stamped:
    """A message that starts with a std_msgs/Header: its stamp, and its seq where the
    layout has one (sensors count it up; a layout without seq ignores it)."""

    def __init__(self, fmt: WireFormat, frame_id: str, seq: bool) -> None:
        self.wire = (fmt, seq)
        self.frame_id = frame_id
        self._out = _Layout(fmt)
        self._stamp_at = self._out.header(frame_id, seq)
        self._seq_at = self._stamp_at - 4 if seq else -1
        self._stamp = _stamp_struct(fmt)

    def _finish(self, buf: bytearray, sec: int, nanosec: int, seq: int) -> bytes:
        self._stamp.pack_into(buf, self._stamp_at, sec, nanosec)
        if self._seq_at >= 0:
            _U32.pack_into(buf, self._seq_at, seq & 0xFFFFFFFF)
        return bytes(buf)


_IMU = struct.Struct("<37d")


class ImuWriter(_Stamped):
    """sensor_msgs/Imu for one frame: everything after the Header is 37 float64."""

    def __init__(self, fmt: WireFormat, frame_id: str, seq: bool = True) -> None:
        super().__init__(fmt, frame_id, seq)
        self._at = self._out.reserve(_IMU.size, 8)
        self._buf = self._out.buf

    def encode(
        self,
        sec: int,
        nanosec: int,
        *,
        orientation_xyzw: Sequence[float],
        orientation_covariance: Sequence[float],
        angular_velocity: Sequence[float],
        angular_velocity_covariance: Sequence[float],
        linear_acceleration: Sequence[float],
        linear_acceleration_covariance: Sequence[float],
        seq: int = 0,
    ) -> bytes:
        """The payload (covariances row-major 3x3, vectors x, y, z)."""
        _IMU.pack_into(
            self._buf,
            self._at,
            *orientation_xyzw,
            *orientation_covariance,
            *angular_velocity,
            *angular_velocity_covariance,
            *linear_acceleration,
            *linear_acceleration_covariance,
        )
        return self._finish(self._buf, sec, nanosec, seq)


_SCAN = struct.Struct("<7f")


class LaserScanWriter(_Stamped):
    """sensor_msgs/LaserScan for one frame and fixed numbers of ranges and intensities
    (`ranges` and `intensities` are float32 views to write the readings into)."""

    def __init__(
        self, fmt: WireFormat, frame_id: str, ranges: int, intensities: int, seq: bool = True
    ) -> None:
        super().__init__(fmt, frame_id, seq)
        out = self._out
        self._at = out.reserve(_SCAN.size, 4)
        out.u32(ranges)
        ranges_at = out.reserve(4 * ranges, 4)
        out.u32(intensities)
        intensities_at = out.reserve(4 * intensities, 4)
        self._buf = out.buf
        self.ranges = _floats(self._buf, ranges_at, ranges)
        self.intensities = _floats(self._buf, intensities_at, intensities)

    def encode(
        self,
        sec: int,
        nanosec: int,
        *,
        limits: Sequence[float],
        ranges: Sequence[float] | NDArray[np.float32],
        intensities: Sequence[float] | NDArray[np.float32],
        seq: int = 0,
    ) -> bytes:
        """The payload; `limits` are angle_min, angle_max, angle_increment,
        time_increment, scan_time, range_min and range_max."""
        _SCAN.pack_into(self._buf, self._at, *limits)
        self.ranges[:] = ranges
        self.intensities[:] = intensities
        return self._finish(self._buf, sec, nanosec, seq)


_ODOM = struct.Struct("<85d")


class OdometryWriter(_Stamped):
    """nav_msgs/Odometry for one (frame, child frame) pair: after the child frame id,
    pose (7), its covariance (36), twist (6) and its covariance (36), all float64."""

    def __init__(
        self, fmt: WireFormat, frame_id: str, child_frame_id: str, seq: bool = True
    ) -> None:
        super().__init__(fmt, frame_id, seq)
        self.child_frame_id = child_frame_id
        self._out.string(child_frame_id)
        self._at = self._out.reserve(_ODOM.size, 8)
        self._buf = self._out.buf

    def encode(
        self,
        sec: int,
        nanosec: int,
        *,
        pose: Sequence[float],
        pose_covariance: Sequence[float],
        twist: Sequence[float],
        twist_covariance: Sequence[float],
        seq: int = 0,
    ) -> bytes:
        """The payload; `pose` is (x, y, z, qx, qy, qz, qw), `twist` (linear x, y, z,
        angular x, y, z), covariances row-major 6x6."""
        _ODOM.pack_into(self._buf, self._at, *pose, *pose_covariance, *twist, *twist_covariance)
        return self._finish(self._buf, sec, nanosec, seq)
