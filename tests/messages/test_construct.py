"""Default construction, keyword overrides and from_dict validation."""

from __future__ import annotations

import numpy as np
import pytest

from simbridge.errors import MessageError
from simbridge.messages import MessageRegistry


def test_new_twist_is_zero_and_mutable(registry: MessageRegistry) -> None:
    twist = registry.new("geometry_msgs/Twist")
    assert (twist.linear.x, twist.linear.y, twist.angular.z) == (0.0, 0.0, 0.0)
    twist.linear.x = 0.5
    twist.angular.z = -1.25
    assert registry.encode(twist)[:8] == np.float64(0.5).tobytes()
    assert registry.decode(registry.encode(twist), "geometry_msgs/Twist") == twist
    assert type(twist) is registry.msg_class("geometry_msgs/msg/Twist")


def test_defaults_cover_every_field_kind(registry: MessageRegistry) -> None:
    info = registry.new("sensor_msgs/CameraInfo")
    assert info.header.stamp.sec == 0
    assert info.header.frame_id == ""
    assert info.D.dtype == np.float64
    assert info.D.shape == (0,)
    assert info.K.shape == (9,)
    assert not info.K.any()
    assert info.roi.do_rectify is False
    fresh = registry.new("sensor_msgs/CameraInfo")
    fresh.K[0] = 1.0
    assert info.K[0] == 0.0  # no shared mutable defaults
    cloud = registry.new("sensor_msgs/PointCloud2")
    assert cloud.fields == []
    assert cloud.data.dtype == np.uint8
    marker = registry.new("visualization_msgs/Marker")
    assert marker.lifetime.sec == 0
    assert marker.points == []
    assert registry.new("std_msgs/Empty") == registry.decode(b"", "std_msgs/Empty")


def test_keyword_overrides_convert_values(registry: MessageRegistry) -> None:
    state = registry.new(
        "sensor_msgs/JointState",
        name=["j1", "j2"],
        position=[0.1, 0.2],
        header={"frame_id": "base", "stamp": {"secs": 3, "nsecs": 4}},
    )
    assert state.name == ["j1", "j2"]
    assert state.position.dtype == np.float64
    assert state.position.tolist() == [0.1, 0.2]
    assert (state.header.stamp.sec, state.header.stamp.nanosec) == (3, 4)
    assert state.velocity.shape == (0,)


def test_from_dict_partial_nested_and_positional(registry: MessageRegistry) -> None:
    twist = registry.from_dict("geometry_msgs/Twist", {"linear": {"x": 1}, "angular": [0, 0, 2]})
    assert twist.linear.x == 1.0
    assert isinstance(twist.linear.x, float)
    assert twist.angular.z == 2.0
    assert registry.from_dict("geometry_msgs/Twist", {}) == registry.new("geometry_msgs/Twist")
    existing = registry.new("geometry_msgs/Vector3", x=7.0)
    assert registry.from_dict("geometry_msgs/Twist", {"linear": existing}).linear is existing


def test_time_forms(registry: MessageRegistry) -> None:
    def stamp(value: object) -> tuple[int, int]:
        header = registry.from_dict("std_msgs/Header", {"stamp": value})
        return header.stamp.sec, header.stamp.nanosec

    assert stamp({"secs": 5, "nsecs": 6}) == (5, 6)
    assert stamp({"sec": 5, "nanosec": 6}) == (5, 6)
    assert stamp(2.5) == (2, 500_000_000)
    assert stamp({"secs": 1, "nsecs": 1_500_000_000}) == (2, 500_000_000)
    now = stamp("now")
    assert now[0] > 1_600_000_000
    duration = registry.from_dict("trajectory_msgs/JointTrajectoryPoint", {"time_from_start": -1.5})
    assert (duration.time_from_start.sec, duration.time_from_start.nanosec) == (-2, 500_000_000)
    with pytest.raises(MessageError, match=r"std_msgs/Header\.stamp: a time has keys"):
        stamp({"seconds": 1})
    with pytest.raises(MessageError, match="out of range"):
        stamp(-1)


def test_unknown_field_names_field_and_valid_fields(registry: MessageRegistry) -> None:
    with pytest.raises(MessageError) as info:
        registry.from_dict("geometry_msgs/Twist", {"linear": {"w": 1.0}})
    text = str(info.value)
    assert "geometry_msgs/Twist.linear" in text
    assert "'w'" in text
    assert "valid fields: x, y, z" in text
    with pytest.raises(MessageError, match="valid fields: linear, angular"):
        registry.new("geometry_msgs/Twist", speed=1.0)


@pytest.mark.parametrize(
    ("name", "data", "pattern"),
    [
        ("std_msgs/String", {"data": 5}, r"\.data: expected a string"),
        ("std_msgs/Float64", {"data": "x"}, r"expected a number \(float64\)"),
        ("std_msgs/UInt8", {"data": 256}, r"256 is out of range for uint8"),
        ("std_msgs/Int8", {"data": 1.5}, r"expected an integer \(int8\)"),
        ("std_msgs/Bool", {"data": 2}, r"expected a bool"),
        ("geometry_msgs/Twist", {"linear": 3}, r"expected a mapping of geometry_msgs/Vector3"),
        ("geometry_msgs/Twist", {"linear": [1, 2]}, r"needs 3 values \(x, y, z\), got 2"),
        ("sensor_msgs/Imu", {"orientation_covariance": [0.0] * 8}, r"needs exactly 9 elements"),
        ("sensor_msgs/JointState", {"position": ["a"]}, r"expected numbers for float64"),
        ("sensor_msgs/JointState", {"position": [[1.0]]}, r"flat list"),
        ("sensor_msgs/Image", {"data": [300]}, r"out of range for uint8"),
        ("sensor_msgs/Image", {"data": "@@not base64"}, r"must be base64"),
        ("sensor_msgs/JointState", {"name": "j1"}, r"expected a list of string"),
        ("nav_msgs/Path", {"poses": [{"pose": {"position": {"q": 1}}}]}, r"poses\[0\]\.pose"),
    ],
)
def test_invalid_values_name_the_field(
    registry: MessageRegistry, name: str, data: dict[str, object], pattern: str
) -> None:
    with pytest.raises(MessageError, match=pattern):
        registry.from_dict(name, data)


def test_byte_arrays_accept_bytes_base64_and_lists(registry: MessageRegistry) -> None:
    for value in (b"\x01\x02\xff", "AQL/", [1, 2, 255], np.array([1, 2, 255], dtype=np.uint8)):
        image = registry.from_dict("sensor_msgs/Image", {"data": value})
        assert image.data.dtype == np.uint8
        assert image.data.tolist() == [1, 2, 255]
    signed = registry.from_dict("std_msgs/ByteMultiArray", {"data": b"\xff"})
    assert signed.data.dtype == np.int8
    assert signed.data.tolist() == [-1]
