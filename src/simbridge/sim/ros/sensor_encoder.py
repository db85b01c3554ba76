"""Sensor messages serialized by the precompiled writers instead of the generic codec.

Sensors build ROS 1 message objects; for the hot kinds (sensor_msgs/Imu,
sensor_msgs/LaserScan, nav_msgs/Odometry and odometry's tf2_msgs/TFMessage) the
numbers are copied from those objects into a reused buffer laid out once per topic
(`simbridge.messages.fastwire`), in ROS 1 binary or in CDR with ROS 2 layouts. That
skips the translation to ROS 2 layouts and the field-by-field encoding; the bytes are
the codec's (tests/messages/test_fastwire.py). Other kinds return None: the caller
encodes them the generic way.
"""

from __future__ import annotations

from typing import Any

from simbridge.messages import WireFormat
from simbridge.messages.fastwire import ImuWriter, LaserScanWriter, OdometryWriter, TFWriter
from simbridge.sim.sensors.rosmsg import Publication

__all__ = ["SensorEncoder"]

Wire = tuple[WireFormat, bool]
"""(wire format, the Header has ROS 1's seq)."""


def _xyz(v: Any) -> tuple[float, float, float]:
    return v.x, v.y, v.z


def _xyzw(q: Any) -> tuple[float, float, float, float]:
    return q.x, q.y, q.z, q.w


class SensorEncoder:
    """One writer per topic, rebuilt when the wire, a frame id or a size changes."""

    def __init__(self) -> None:
        self._writers: dict[str, Any] = {}

    def encode(self, publication: Publication, wire: Wire) -> bytes | None:
        """The payload of `publication` in `wire`, or None for a kind without a writer."""
        kind, msg = publication.msgtype, publication.message
        if kind == "sensor_msgs/Imu":
            return self._imu(publication.topic, msg, wire)
        if kind == "sensor_msgs/LaserScan":
            return self._scan(publication.topic, msg, wire)
        if kind == "nav_msgs/Odometry":
            return self._odometry(publication.topic, msg, wire)
        if kind == "tf2_msgs/TFMessage":
            return self._tf(publication.topic, msg, wire)
        return None

    def _imu(self, topic: str, msg: Any, wire: Wire) -> bytes:
        h = msg.header
        writer = self._writers.get(topic)
        if not (
            isinstance(writer, ImuWriter) and writer.wire == wire and writer.frame_id == h.frame_id
        ):
            writer = self._writers[topic] = ImuWriter(wire[0], h.frame_id, seq=wire[1])
        return writer.encode(
            h.stamp.sec,
            h.stamp.nanosec,
            orientation_xyzw=_xyzw(msg.orientation),
            orientation_covariance=msg.orientation_covariance.tolist(),
            angular_velocity=_xyz(msg.angular_velocity),
            angular_velocity_covariance=msg.angular_velocity_covariance.tolist(),
            linear_acceleration=_xyz(msg.linear_acceleration),
            linear_acceleration_covariance=msg.linear_acceleration_covariance.tolist(),
            seq=h.seq,
        )

    def _scan(self, topic: str, msg: Any, wire: Wire) -> bytes:
        h = msg.header
        sizes = (len(msg.ranges), len(msg.intensities))
        writer = self._writers.get(topic)
        if not (
            isinstance(writer, LaserScanWriter)
            and writer.wire == wire
            and writer.frame_id == h.frame_id
            and (len(writer.ranges), len(writer.intensities)) == sizes
        ):
            writer = self._writers[topic] = LaserScanWriter(
                wire[0], h.frame_id, sizes[0], sizes[1], seq=wire[1]
            )
        limits = [msg.angle_min, msg.angle_max, msg.angle_increment, msg.time_increment]
        limits += [msg.scan_time, msg.range_min, msg.range_max]
        return writer.encode(
            h.stamp.sec,
            h.stamp.nanosec,
            limits=limits,
            ranges=msg.ranges,
            intensities=msg.intensities,
            seq=h.seq,
        )

    def _odometry(self, topic: str, msg: Any, wire: Wire) -> bytes:
        h = msg.header
        writer = self._writers.get(topic)
        if not (
            isinstance(writer, OdometryWriter)
            and writer.wire == wire
            and writer.frame_id == h.frame_id
            and writer.child_frame_id == msg.child_frame_id
        ):
            writer = self._writers[topic] = OdometryWriter(
                wire[0], h.frame_id, msg.child_frame_id, seq=wire[1]
            )
        pose, twist = msg.pose.pose, msg.twist.twist
        return writer.encode(
            h.stamp.sec,
            h.stamp.nanosec,
            pose=(*_xyz(pose.position), *_xyzw(pose.orientation)),
            pose_covariance=msg.pose.covariance.tolist(),
            twist=(*_xyz(twist.linear), *_xyz(twist.angular)),
            twist_covariance=msg.twist.covariance.tolist(),
            seq=h.seq,
        )

    def _tf(self, topic: str, msg: Any, wire: Wire) -> bytes | None:
        transforms = msg.transforms
        if not transforms:
            return None
        stamp = transforms[0].header.stamp
        for t in transforms:  # the writer stamps every transform alike, with seq 0
            if t.header.stamp != stamp or t.header.seq != 0:
                return None
        frames = tuple((t.header.frame_id, t.child_frame_id) for t in transforms)
        writer = self._writers.get(topic)
        if not (isinstance(writer, TFWriter) and writer.wire == wire and writer.frames == frames):
            writer = self._writers[topic] = TFWriter(wire[0], frames, seq=wire[1])
        poses = [(*_xyz(t.transform.translation), *_xyzw(t.transform.rotation)) for t in transforms]
        return writer.encode(stamp.sec, stamp.nanosec, poses)
