"""Builds the ROS 1 (noetic) message objects that sensors publish.

Messages are instances of the message registry's classes (rosbags noetic dataclasses
plus shipped packages such as tf2_msgs), built directly for speed, so a reading goes
straight to the codec. Type names are ROS 1 canonical (`pkg/Type`). Against a ROS 2
endpoint, `sim/ros/sensor_publisher.py` translates them to the ROS 2 layouts on the way out.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from simbridge.messages import default_registry
from simbridge.sim.sensors.frames import Pose

__all__ = [
    "Publication",
    "header",
    "new_message",
    "point_cloud2",
    "point_field_datatype",
    "pose_message",
    "quaternion",
    "stamp_from_time",
    "transform_stamped",
    "vector3",
]


@dataclass(frozen=True)
class Publication:
    """One message a sensor wants published: topic, ROS 1 type name and the message."""

    topic: str
    msgtype: str
    message: Any


@cache
def _message_class(msgtype: str) -> Any:
    return default_registry().msg_class(msgtype)


def new_message(msgtype: str, **fields: Any) -> Any:
    """Instantiate the message `pkg/Type`; every field must be given."""
    return _message_class(msgtype)(**fields)


def stamp_from_time(sim_time: float) -> Any:
    """A ROS time stamp (sec, nsec) for a simulated time in seconds."""
    total_ns = round(sim_time * 1e9)
    sec, nanosec = divmod(total_ns, 1_000_000_000)
    return new_message("builtin_interfaces/Time", sec=sec, nanosec=nanosec)


def header(sim_time: float, frame_id: str, seq: int = 0) -> Any:
    """A std_msgs/Header stamped in simulated time."""
    return new_message(
        "std_msgs/Header", seq=seq, stamp=stamp_from_time(sim_time), frame_id=frame_id
    )


def vector3(values: NDArray[np.float64]) -> Any:
    """geometry_msgs/Vector3 from a 3-vector."""
    return new_message(
        "geometry_msgs/Vector3", x=float(values[0]), y=float(values[1]), z=float(values[2])
    )


def quaternion(wxyz: NDArray[np.float64]) -> Any:
    """geometry_msgs/Quaternion from (w, x, y, z)."""
    return new_message(
        "geometry_msgs/Quaternion",
        x=float(wxyz[1]),
        y=float(wxyz[2]),
        z=float(wxyz[3]),
        w=float(wxyz[0]),
    )


def pose_message(pose: Pose) -> Any:
    """geometry_msgs/Pose of a rigid transform."""
    point = new_message(
        "geometry_msgs/Point",
        x=float(pose.position[0]),
        y=float(pose.position[1]),
        z=float(pose.position[2]),
    )
    return new_message(
        "geometry_msgs/Pose", position=point, orientation=quaternion(pose.quat_wxyz())
    )


def transform_stamped(sim_time: float, parent: str, child: str, pose: Pose) -> Any:
    """geometry_msgs/TransformStamped placing `child` at `pose` in `parent`."""
    transform = new_message(
        "geometry_msgs/Transform",
        translation=vector3(pose.position),
        rotation=quaternion(pose.quat_wxyz()),
    )
    return new_message(
        "geometry_msgs/TransformStamped",
        header=header(sim_time, parent),
        child_frame_id=child,
        transform=transform,
    )


_DATATYPES = {
    np.dtype(np.int8): 1,
    np.dtype(np.uint8): 2,
    np.dtype(np.int16): 3,
    np.dtype(np.uint16): 4,
    np.dtype(np.int32): 5,
    np.dtype(np.uint32): 6,
    np.dtype(np.float32): 7,
    np.dtype(np.float64): 8,
}


def point_field_datatype(dtype: np.dtype[Any]) -> int:
    """sensor_msgs/PointField datatype constant for a numpy scalar dtype."""
    return _DATATYPES[np.dtype(dtype).newbyteorder("=")]


def point_cloud2(header_msg: Any, points: NDArray[Any], *, height: int, width: int) -> Any:
    """sensor_msgs/PointCloud2 from a little-endian structured array (one record per point).

    The cloud is dense (is_dense) when no float field holds a NaN.
    """
    dtype = points.dtype
    assert dtype.fields is not None
    fields = []
    for name, (field_dtype, offset, *_rest) in dtype.fields.items():
        fields.append(
            new_message(
                "sensor_msgs/PointField",
                name=name,
                offset=offset,
                datatype=point_field_datatype(field_dtype),
                count=1,
            )
        )
    dense = all(
        not np.isnan(points[name]).any()
        for name, (field_dtype, *_rest) in dtype.fields.items()
        if np.issubdtype(field_dtype, np.floating)
    )
    return new_message(
        "sensor_msgs/PointCloud2",
        header=header_msg,
        height=height,
        width=width,
        fields=fields,
        is_bigendian=False,
        point_step=dtype.itemsize,
        row_step=dtype.itemsize * width,
        data=np.frombuffer(np.ascontiguousarray(points).tobytes(), dtype=np.uint8),
        is_dense=dense,
    )
