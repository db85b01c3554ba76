"""Build and read the ROS messages the simulator exchanges, in the layouts of the registry
given (ROS 1 noetic, or ROS 2 where Header has no seq)."""

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
    """Builds stamped messages from sim time, with the registry's message classes cached
    (constructing dataclasses directly is several times faster than `registry.new`)."""

    def __init__(self, registry: MessageRegistry) -> None:
        self.registry = registry
        self._classes: dict[str, Any] = {}
        self._seq = {"seq": 0} if registry.protocol == "ROS1" else {}
        """Header fields beyond stamp and frame_id: ROS 1's seq (left 0; ROS 2 has none)."""

    def cls(self, name: str) -> Any:
        """The message class of `name` (cached)."""
        found = self._classes.get(name)
        if found is None:
            found = self._classes[name] = self.registry.msg_class(name)
        return found

    def time(self, seconds: float) -> Any:
        """A Time message for `seconds` (rounded to the nanosecond)."""
        total = round(seconds * 1e9)
        return self.cls("time")(sec=total // 10**9, nanosec=total % 10**9)

    def header(self, seconds: float, frame_id: str = "") -> Any:
        """A std_msgs/Header stamped at `seconds`."""
        return self.header_at(self.time(seconds), frame_id)

    def header_at(self, stamp: Any, frame_id: str) -> Any:
        """A std_msgs/Header with the Time message `stamp`."""
        return self.cls("std_msgs/Header")(stamp=stamp, frame_id=frame_id, **self._seq)


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
    names = list(positions)
    return stamps.cls("sensor_msgs/JointState")(
        header=stamps.header(now),
        name=names,
        position=np.array([positions[n] for n in names], dtype=np.float64),
        velocity=np.array([velocities[n] for n in names], dtype=np.float64),
        effort=np.array([efforts[n] for n in names], dtype=np.float64),
    )


def tf_message(stamps: StampMaker, now: float, edges: Sequence[tuple[str, str, Transform]]) -> Any:
    """tf2_msgs/TFMessage with one TransformStamped per (parent, child, child-in-parent)."""
    vector, quaternion = stamps.cls("geometry_msgs/Vector3"), stamps.cls("geometry_msgs/Quaternion")
    transform, stamped = (
        stamps.cls("geometry_msgs/Transform"),
        stamps.cls("geometry_msgs/TransformStamped"),
    )
    stamp = stamps.time(now)
    transforms = []
    for parent, child, tf in edges:
        x, y, z = tf.xyz
        qx, qy, qz, qw = tf.quat_xyzw
        transforms.append(
            stamped(
                header=stamps.header_at(stamp, parent),
                child_frame_id=child,
                transform=transform(
                    translation=vector(x=x, y=y, z=z), rotation=quaternion(x=qx, y=qy, z=qz, w=qw)
                ),
            )
        )
    return stamps.cls("tf2_msgs/TFMessage")(transforms=transforms)


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
