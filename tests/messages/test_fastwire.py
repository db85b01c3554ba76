"""The precompiled sim-state serializers write exactly the generic codec's bytes."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.messages import MessageRegistry, WireFormat, default_registry, ros2_registry
from simbridge.messages.fastwire import (
    ClockWriter,
    ImuWriter,
    JointStateWriter,
    LaserScanWriter,
    OdometryWriter,
    TFWriter,
)

COMBOS = [
    pytest.param("ROS1", "ros1", id="ros1-layouts-ros1"),
    pytest.param("ROS1", "cdr", id="ros1-layouts-cdr"),
    pytest.param("ROS2", "cdr", id="ros2-layouts-cdr"),
    pytest.param("ROS2", "ros1", id="ros2-layouts-ros1"),
]

names = st.text(st.characters(codec="utf-8", blacklist_characters="\x00"), max_size=12)
floats = st.floats(allow_nan=False, width=64)
secs = st.integers(0, 2**31 - 1)
nsecs = st.integers(0, 10**9 - 1)


def _registry(generation: str) -> MessageRegistry:
    return default_registry() if generation == "ROS1" else ros2_registry()


def _time(reg: MessageRegistry, sec: int, nanosec: int) -> Any:
    return reg.msg_class("time")(sec=sec, nanosec=nanosec)


def _header(reg: MessageRegistry, sec: int, nanosec: int, frame: str, seq_no: int = 0) -> Any:
    seq = {"seq": seq_no} if reg.protocol == "ROS1" else {}
    return reg.msg_class("std_msgs/Header")(stamp=_time(reg, sec, nanosec), frame_id=frame, **seq)


@pytest.mark.parametrize(("generation", "fmt"), COMBOS)
@settings(max_examples=60, deadline=None)
@given(
    data=st.lists(st.tuples(names, floats, floats, floats), max_size=9),
    frame=names,
    stamp=st.tuples(secs, nsecs),
)
def test_joint_state_bytes(
    generation: str,
    fmt: WireFormat,
    data: list[tuple[str, float, float, float]],
    frame: str,
    stamp: tuple[int, int],
) -> None:
    reg = _registry(generation)
    sec, nanosec = stamp
    joint_names = [d[0] for d in data]
    pos, vel, eff = [d[1] for d in data], [d[2] for d in data], [d[3] for d in data]
    msg = reg.msg_class("sensor_msgs/JointState")(
        header=_header(reg, sec, nanosec, frame),
        name=joint_names,
        position=np.array(pos, dtype=np.float64),
        velocity=np.array(vel, dtype=np.float64),
        effort=np.array(eff, dtype=np.float64),
    )
    writer = JointStateWriter(fmt, joint_names, frame, seq=reg.protocol == "ROS1")
    expected = reg.codec("sensor_msgs/JointState").encode(msg, fmt)
    assert writer.encode(sec, nanosec, pos, vel, eff) == expected
    # The buffer is reused: a second message with other values is right too.
    assert writer.encode(0, 1, [0.5] * len(pos), vel, eff) == reg.codec(
        "sensor_msgs/JointState"
    ).encode(
        reg.msg_class("sensor_msgs/JointState")(
            header=_header(reg, 0, 1, frame),
            name=joint_names,
            position=np.full(len(pos), 0.5),
            velocity=np.array(vel, dtype=np.float64),
            effort=np.array(eff, dtype=np.float64),
        ),
        fmt,
    )


@pytest.mark.parametrize(("generation", "fmt"), COMBOS)
@settings(max_examples=60, deadline=None)
@given(
    edges=st.lists(st.tuples(names, names, st.tuples(*[floats] * 7)), max_size=8),
    sec=secs,
    nanosec=nsecs,
)
def test_tf_bytes(
    generation: str,
    fmt: WireFormat,
    edges: list[tuple[str, str, tuple[float, ...]]],
    sec: int,
    nanosec: int,
) -> None:
    reg = _registry(generation)
    vector, quat = reg.msg_class("geometry_msgs/Vector3"), reg.msg_class("geometry_msgs/Quaternion")
    transform = reg.msg_class("geometry_msgs/Transform")
    stamped = reg.msg_class("geometry_msgs/TransformStamped")
    msg = reg.msg_class("tf2_msgs/TFMessage")(
        transforms=[
            stamped(
                header=_header(reg, sec, nanosec, parent),
                child_frame_id=child,
                transform=transform(
                    translation=vector(x=p[0], y=p[1], z=p[2]),
                    rotation=quat(x=p[3], y=p[4], z=p[5], w=p[6]),
                ),
            )
            for parent, child, p in edges
        ]
    )
    writer = TFWriter(fmt, [(p, c) for p, c, _ in edges], seq=reg.protocol == "ROS1")
    got = writer.encode(sec, nanosec, [p for _, _, p in edges])
    assert got == reg.codec("tf2_msgs/TFMessage").encode(msg, fmt)


@pytest.mark.parametrize(("generation", "fmt"), COMBOS)
@settings(max_examples=60, deadline=None)
@given(sec=secs, nanosec=nsecs)
def test_clock_bytes(generation: str, fmt: WireFormat, sec: int, nanosec: int) -> None:
    reg = _registry(generation)
    msg = reg.msg_class("rosgraph_msgs/Clock")(clock=_time(reg, sec, nanosec))
    writer = ClockWriter(fmt)
    assert writer.encode(sec, nanosec) == reg.codec("rosgraph_msgs/Clock").encode(msg, fmt)


def test_ros1_stamp_beyond_2038() -> None:
    """ROS 1 `time` is unsigned: seconds past 2**31 serialize as the codec does."""
    reg = default_registry()
    msg = reg.msg_class("rosgraph_msgs/Clock")(clock=_time(reg, 2**31 + 5, 7))
    assert ClockWriter("ros1").encode(2**31 + 5, 7) == reg.codec("rosgraph_msgs/Clock").encode(
        msg, "ros1"
    )


def test_wrong_value_count_is_an_error() -> None:
    writer = JointStateWriter("ros1", ["a", "b"])
    with pytest.raises(Exception, match="pack_into"):
        writer.encode(0, 0, [1.0], [1.0, 2.0], [1.0, 2.0])


seqs = st.integers(0, 2**32 - 1)
floats32 = st.floats(allow_nan=False, width=32)


def _vector3(reg: MessageRegistry, v: tuple[float, ...]) -> Any:
    return reg.msg_class("geometry_msgs/Vector3")(x=v[0], y=v[1], z=v[2])


@pytest.mark.parametrize(("generation", "fmt"), COMBOS)
@settings(max_examples=40, deadline=None)
@given(
    values=st.lists(floats, min_size=37, max_size=37),
    head=st.tuples(names, secs, nsecs, seqs),
)
def test_imu_bytes(
    generation: str, fmt: WireFormat, values: list[float], head: tuple[str, int, int, int]
) -> None:
    reg = _registry(generation)
    frame, sec, nanosec, seq = head
    quat, cov_o, gyro, cov_g, accel, cov_a = (
        values[0:4],
        values[4:13],
        values[13:16],
        values[16:25],
        values[25:28],
        values[28:37],
    )
    msg = reg.msg_class("sensor_msgs/Imu")(
        header=_header(reg, sec, nanosec, frame, seq),
        orientation=reg.msg_class("geometry_msgs/Quaternion")(
            x=quat[0], y=quat[1], z=quat[2], w=quat[3]
        ),
        orientation_covariance=np.array(cov_o),
        angular_velocity=_vector3(reg, tuple(gyro)),
        angular_velocity_covariance=np.array(cov_g),
        linear_acceleration=_vector3(reg, tuple(accel)),
        linear_acceleration_covariance=np.array(cov_a),
    )
    writer = ImuWriter(fmt, frame, seq=reg.protocol == "ROS1")
    got = writer.encode(
        sec,
        nanosec,
        orientation_xyzw=quat,
        orientation_covariance=cov_o,
        angular_velocity=gyro,
        angular_velocity_covariance=cov_g,
        linear_acceleration=accel,
        linear_acceleration_covariance=cov_a,
        seq=seq,
    )
    assert got == reg.codec("sensor_msgs/Imu").encode(msg, fmt)


@pytest.mark.parametrize(("generation", "fmt"), COMBOS)
@settings(max_examples=40, deadline=None)
@given(
    limits=st.lists(floats32, min_size=7, max_size=7),
    scan=st.tuples(st.lists(floats32, max_size=20), st.booleans()),
    head=st.tuples(names, secs, nsecs, seqs),
)
def test_laser_scan_bytes(
    generation: str,
    fmt: WireFormat,
    limits: list[float],
    scan: tuple[list[float], bool],
    head: tuple[str, int, int, int],
) -> None:
    """Also REP 117's +-inf ranges, empty scans and a scan without intensities."""
    reg = _registry(generation)
    frame, sec, nanosec, seq = head
    ranges, with_intensities = scan
    ranges_f32 = np.array(ranges, dtype=np.float32)
    intensities = ranges_f32[::-1].copy() if with_intensities else np.zeros(0, np.float32)
    keys = ["angle_min", "angle_max", "angle_increment", "time_increment", "scan_time"]
    keys += ["range_min", "range_max"]
    msg = reg.msg_class("sensor_msgs/LaserScan")(
        header=_header(reg, sec, nanosec, frame, seq),
        **dict(zip(keys, limits, strict=True)),
        ranges=ranges_f32,
        intensities=intensities,
    )
    writer = LaserScanWriter(fmt, frame, len(ranges), len(intensities), seq=reg.protocol == "ROS1")
    got = writer.encode(
        sec, nanosec, limits=limits, ranges=ranges_f32, intensities=intensities, seq=seq
    )
    assert got == reg.codec("sensor_msgs/LaserScan").encode(msg, fmt)


@pytest.mark.parametrize(("generation", "fmt"), COMBOS)
@settings(max_examples=40, deadline=None)
@given(
    values=st.lists(floats, min_size=85, max_size=85),
    child=names,
    head=st.tuples(names, secs, nsecs, seqs),
)
def test_odometry_bytes(
    generation: str,
    fmt: WireFormat,
    values: list[float],
    child: str,
    head: tuple[str, int, int, int],
) -> None:
    reg = _registry(generation)
    frame, sec, nanosec, seq = head
    pose, pose_cov, twist, twist_cov = values[0:7], values[7:43], values[43:49], values[49:85]
    cls = reg.msg_class
    msg = cls("nav_msgs/Odometry")(
        header=_header(reg, sec, nanosec, frame, seq),
        child_frame_id=child,
        pose=cls("geometry_msgs/PoseWithCovariance")(
            pose=cls("geometry_msgs/Pose")(
                position=cls("geometry_msgs/Point")(x=pose[0], y=pose[1], z=pose[2]),
                orientation=cls("geometry_msgs/Quaternion")(
                    x=pose[3], y=pose[4], z=pose[5], w=pose[6]
                ),
            ),
            covariance=np.array(pose_cov),
        ),
        twist=cls("geometry_msgs/TwistWithCovariance")(
            twist=cls("geometry_msgs/Twist")(
                linear=_vector3(reg, tuple(twist[0:3])), angular=_vector3(reg, tuple(twist[3:6]))
            ),
            covariance=np.array(twist_cov),
        ),
    )
    writer = OdometryWriter(fmt, frame, child, seq=reg.protocol == "ROS1")
    got = writer.encode(
        sec,
        nanosec,
        pose=pose,
        pose_covariance=pose_cov,
        twist=twist,
        twist_covariance=twist_cov,
        seq=seq,
    )
    assert got == reg.codec("nav_msgs/Odometry").encode(msg, fmt)


def test_joint_state_views_write_in_place() -> None:
    """Values written into the writer's views land in the payload, as encode's do."""
    writer = JointStateWriter("cdr", ["a", "b"], seq=False)
    expected = writer.encode(3, 4, [1.0, 2.0], [3.0, 4.0], [5.0, 6.0])
    writer.encode(0, 0, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0])
    writer.position[:] = [1.0, 2.0]
    writer.velocity[:] = [3.0, 4.0]
    writer.effort[:] = [5.0, 6.0]
    assert writer.finish(3, 4) == expected
