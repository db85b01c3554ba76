"""Build and read the ROS messages the simulator exchanges (rosbags noetic dataclasses)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from simbridge.errors import SimError
from simbridge.messages import MessageRegistry
from simbridge.sim.control.trajectory import Trajectory, TrajectoryPoint
from simbridge.sim.urdf.transforms import Transform

__all__ = [
    "StampMaker",
    "duration_seconds",
    "joint_state_message",
    "tf_message",
    "trajectory_from_message",
]


class StampMaker:
    """Turns sim time in seconds into `builtin_interfaces/Time` messages."""

    def __init__(self, registry: MessageRegistry) -> None:
        self.registry = registry

    def time(self, seconds: float) -> Any:
        """A Time message for `seconds` (rounded to the nanosecond)."""
        total = round(seconds * 1e9)
        return self.registry.new(
            "builtin_interfaces/Time", sec=total // 10**9, nanosec=total % 10**9
        )

    def header(self, seconds: float, frame_id: str = "") -> Any:
        """A std_msgs/Header stamped at `seconds`."""
        header = self.registry.new("std_msgs/Header", frame_id=frame_id)
        header.stamp = self.time(seconds)
        return header


def duration_seconds(duration: Any) -> float:
    """Seconds of a `builtin_interfaces/Duration` (or Time) message."""
    return float(duration.sec) + float(duration.nanosec) * 1e-9


def joint_state_message(
    stamps: StampMaker,
    now: float,
    positions: Mapping[str, float],
    velocities: Mapping[str, float],
    efforts: Mapping[str, float],
) -> Any:
    """sensor_msgs/JointState with every joint in `positions` order."""
    msg = stamps.registry.new("sensor_msgs/JointState")
    msg.header = stamps.header(now)
    msg.name = list(positions)
    msg.position = np.array([positions[n] for n in msg.name], dtype=np.float64)
    msg.velocity = np.array([velocities[n] for n in msg.name], dtype=np.float64)
    msg.effort = np.array([efforts[n] for n in msg.name], dtype=np.float64)
    return msg


def tf_message(stamps: StampMaker, now: float, edges: Sequence[tuple[str, str, Transform]]) -> Any:
    """tf2_msgs/TFMessage with one TransformStamped per (parent, child, child-in-parent)."""
    reg = stamps.registry
    msg = reg.new("tf2_msgs/TFMessage")
    for parent, child, tf in edges:
        stamped = reg.new("geometry_msgs/TransformStamped", child_frame_id=child)
        stamped.header = stamps.header(now, parent)
        x, y, z = tf.xyz
        qx, qy, qz, qw = tf.quat_xyzw
        stamped.transform.translation = reg.new("geometry_msgs/Vector3", x=x, y=y, z=z)
        stamped.transform.rotation = reg.new("geometry_msgs/Quaternion", x=qx, y=qy, z=qz, w=qw)
        msg.transforms.append(stamped)
    return msg


def trajectory_from_message(msg: Any) -> Trajectory | None:
    """The Trajectory in a trajectory_msgs/JointTrajectory (None for an empty one, which
    means "stop"); velocities are used only when every point has them."""
    if not msg.points:
        return None
    names = tuple(str(n) for n in msg.joint_names)
    with_velocities = all(len(p.velocities) == len(names) for p in msg.points)
    points = []
    for i, point in enumerate(msg.points):
        positions = tuple(float(v) for v in point.positions)
        if len(positions) != len(names):
            raise SimError(
                f"JointTrajectory point {i}: {len(positions)} positions for joints {list(names)}"
            )
        velocities = tuple(float(v) for v in point.velocities) if with_velocities else None
        points.append(
            TrajectoryPoint(duration_seconds(point.time_from_start), positions, velocities)
        )
    return Trajectory(names, tuple(points))
