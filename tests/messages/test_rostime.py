"""ROS 1 `time` (uint32 secs, nsecs) and `duration` (int32 secs, nsecs) against genpy's
serializer from Debian; ROS 2 builtin_interfaces Time (int32 sec, uint32 nanosec) in CDR."""

from __future__ import annotations

import importlib
import io
import json
import struct
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st
from rosbags.typesys import Stores

from simbridge.errors import MessageError
from simbridge.messages import MessageRegistry

genpy = pytest.importorskip("genpy")
std_msgs = importlib.import_module("std_msgs.msg")
sensor_msgs = importlib.import_module("sensor_msgs.msg")

UINT32_MAX = 2**32 - 1
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1
TIME_EDGES = [0, 1, 2**31 - 1, 2**31, 4_000_000_000, UINT32_MAX]
NSEC_EDGES = [0, 1, 999_999_999]


def _genpy_bytes(msg: Any) -> bytes:
    buff = io.BytesIO()
    msg.serialize(buff)
    return buff.getvalue()


@pytest.mark.parametrize("secs", TIME_EDGES)
@pytest.mark.parametrize("nsecs", NSEC_EDGES)
def test_header_stamp_edges_match_genpy(registry: MessageRegistry, secs: int, nsecs: int) -> None:
    golden = struct.pack("<III", 7, secs, nsecs) + struct.pack("<I", 3) + b"map"
    theirs = std_msgs.Header(seq=7, stamp=genpy.Time(secs, nsecs), frame_id="map")
    assert _genpy_bytes(theirs) == golden

    ours = registry.from_dict(
        "std_msgs/Header", {"seq": 7, "stamp": {"secs": secs, "nsecs": nsecs}, "frame_id": "map"}
    )
    assert registry.encode(ours) == golden
    decoded = registry.decode(golden, "std_msgs/Header")
    assert registry.to_dict(decoded)["stamp"] == {"secs": secs, "nsecs": nsecs}
    assert registry.encode(decoded) == golden

    parsed = std_msgs.Header()
    parsed.deserialize(registry.encode(ours))
    assert (parsed.stamp.secs, parsed.stamp.nsecs) == (secs, nsecs)


def test_time_reference_from_the_issue(registry: MessageRegistry) -> None:
    """`time_ref.sec = 4000000000` is `00 28 6b ee` on the wire, as Unity sends it."""
    theirs = sensor_msgs.TimeReference(time_ref=genpy.Time(4_000_000_000, 0), source="gps")
    theirs.header.stamp = genpy.Time(UINT32_MAX, 999_999_999)
    wire = _genpy_bytes(theirs)
    assert bytes.fromhex("00286bee") in wire
    decoded = registry.decode(wire, "sensor_msgs/TimeReference")
    assert decoded.time_ref.sec == 4_000_000_000
    assert decoded.header.stamp.sec == UINT32_MAX
    assert registry.encode(decoded) == wire
    assert (
        registry.encode(registry.from_dict("sensor_msgs/TimeReference", registry.to_dict(decoded)))
        == wire
    )


@pytest.mark.parametrize(
    ("secs", "nsecs"),
    [(0, 0), (-1, 0), (-1, 500_000_000), (INT32_MIN, 0), (INT32_MAX, 999_999_999), (5, 1)],
)
def test_duration_edges_match_genpy(registry: MessageRegistry, secs: int, nsecs: int) -> None:
    golden = struct.pack("<ii", secs, nsecs)
    assert _genpy_bytes(std_msgs.Duration(genpy.Duration(secs, nsecs))) == golden
    ours = registry.from_dict("std_msgs/Duration", {"data": {"secs": secs, "nsecs": nsecs}})
    assert registry.encode(ours) == golden
    assert registry.to_dict(registry.decode(golden, "std_msgs/Duration")) == {
        "data": {"secs": secs, "nsecs": nsecs}
    }


def test_negative_duration_seconds_normalise_like_genpy(registry: MessageRegistry) -> None:
    """-1.5 s is secs -2, nsecs 500000000 in genpy's canonical form, and so in ours."""
    theirs = _genpy_bytes(std_msgs.Duration(genpy.Duration.from_sec(-1.5)))
    assert theirs == struct.pack("<ii", -2, 500_000_000)
    assert registry.encode(registry.from_dict("std_msgs/Duration", {"data": -1.5})) == theirs
    spelled = {"data": {"secs": -1, "nsecs": -500_000_000}}
    assert registry.encode(registry.from_dict("std_msgs/Duration", spelled)) == theirs


def test_negative_duration_nanoseconds_on_the_wire_decode_signed(registry: MessageRegistry) -> None:
    """A peer may send nsecs < 0 (int32): decode keeps it and re-encodes the same bytes."""
    wire = struct.pack("<ii", 3, -250_000_000)
    decoded = registry.decode(wire, "std_msgs/Duration")
    assert (decoded.data.sec, decoded.data.nanosec) == (3, -250_000_000)
    assert registry.encode(decoded) == wire
    theirs = std_msgs.Duration()
    theirs.deserialize(wire)
    assert theirs.data.to_nsec() == 3 * 10**9 - 250_000_000


@given(secs=st.integers(0, UINT32_MAX), nsecs=st.integers(0, 999_999_999))
def test_any_ros1_time_matches_genpy(secs: int, nsecs: int) -> None:
    registry = _shared()
    wire = _genpy_bytes(std_msgs.Time(genpy.Time(secs, nsecs)))
    assert registry.encode(registry.from_dict("std_msgs/Time", {"data": [secs, nsecs]})) == wire
    decoded = registry.decode(wire, "std_msgs/Time")
    assert (decoded.data.sec, decoded.data.nanosec) == (secs, nsecs)


@given(secs=st.integers(INT32_MIN, INT32_MAX), nsecs=st.integers(0, 999_999_999))
def test_any_ros1_duration_matches_genpy(secs: int, nsecs: int) -> None:
    registry = _shared()
    wire = _genpy_bytes(std_msgs.Duration(genpy.Duration(secs, nsecs)))
    assert registry.encode(registry.from_dict("std_msgs/Duration", {"data": [secs, nsecs]})) == wire
    decoded = registry.decode(wire, "std_msgs/Duration")
    assert (decoded.data.sec, decoded.data.nanosec) == (secs, nsecs)


def _shared() -> MessageRegistry:
    from simbridge.messages import default_registry

    return default_registry()


# -- out of range: clear errors naming field, value and range ------------------------------


@pytest.mark.parametrize(
    ("name", "data", "expected"),
    [
        (
            "std_msgs/Header",
            {"stamp": {"secs": 2**32}},
            "time seconds 4294967296 out of range [0, 4294967295]",
        ),
        (
            "std_msgs/Header",
            {"stamp": {"secs": -1}},
            "time seconds -1 out of range [0, 4294967295]",
        ),
        ("std_msgs/Header", {"stamp": -0.5}, "time seconds -1 out of range [0, 4294967295]"),
        (
            "std_msgs/Duration",
            {"data": {"secs": 2**31}},
            "duration seconds 2147483648 out of range [-2147483648, 2147483647]",
        ),
        (
            "std_msgs/Duration",
            {"data": {"secs": INT32_MIN, "nsecs": -1}},
            "duration seconds -2147483649 out of range",
        ),
    ],
)
def test_out_of_range_values_from_data(
    registry: MessageRegistry, name: str, data: dict[str, Any], expected: str
) -> None:
    field = next(iter(data))
    with pytest.raises(MessageError) as info:
        registry.from_dict(name, data)
    assert f"{name}.{field}" in str(info.value)
    assert expected in str(info.value)


@pytest.mark.parametrize(
    ("attr", "value", "expected"),
    [
        (
            "sec",
            2**32,
            "std_msgs/Header.stamp.secs: 4294967296 is out of range for ROS 1 time secs (uint32)"
            " [0, 4294967295]",
        ),
        ("sec", -1, "std_msgs/Header.stamp.secs: -1 is out of range for ROS 1 time secs (uint32)"),
        (
            "nanosec",
            -3,
            "std_msgs/Header.stamp.nsecs: -3 is out of range for ROS 1 time nsecs (uint32)",
        ),
        (
            "sec",
            1.5,
            "std_msgs/Header.stamp.secs: expected an integer (ROS 1 time secs (uint32)), got 1.5",
        ),
    ],
)
def test_out_of_range_values_at_encode(
    registry: MessageRegistry, attr: str, value: object, expected: str
) -> None:
    header = registry.new("std_msgs/Header")
    setattr(header.stamp, attr, value)
    with pytest.raises(MessageError, match="cannot encode std_msgs/Header as ROS 1") as info:
        registry.encode(header)
    assert expected in str(info.value)


def test_out_of_range_duration_at_encode(registry: MessageRegistry) -> None:
    msg = registry.new("std_msgs/Duration")
    msg.data.nanosec = 2**31
    with pytest.raises(MessageError) as info:
        registry.encode(msg)
    text = str(info.value)
    assert "std_msgs/Duration.data.nsecs: 2147483648 is out of range for ROS 1 duration" in text
    assert "(int32) [-2147483648, 2147483647]" in text


def test_other_encode_errors_name_the_field(registry: MessageRegistry) -> None:
    msg = registry.new("sensor_msgs/Imu")
    msg.header.seq = -1
    with pytest.raises(MessageError, match=r"Imu\.header\.seq: -1 is out of range for uint32"):
        registry.encode(msg)
    msg = registry.new("sensor_msgs/Imu")
    msg.orientation_covariance = [0.0] * 9
    with pytest.raises(MessageError, match=r"orientation_covariance: expected a numpy array"):
        registry.encode(msg)


# -- conversions: dict, JSON, YAML, MessagePack carry stamps past 2038 ---------------------


def test_conversions_carry_stamps_past_2038(registry: MessageRegistry) -> None:
    msg = registry.from_yaml(
        "sensor_msgs/TimeReference",
        "{header: {stamp: {secs: 4294967295, nsecs: 999999999}}, time_ref: 4000000000.25}",
    )
    assert registry.to_dict(msg)["time_ref"] == {"secs": 4_000_000_000, "nsecs": 250_000_000}
    text = registry.to_json(msg)
    assert json.loads(text)["header"]["stamp"] == {"secs": UINT32_MAX, "nsecs": 999_999_999}
    wire = registry.encode(msg)
    assert registry.encode(registry.from_json("sensor_msgs/TimeReference", text)) == wire
    packed = registry.to_msgpack(msg)
    assert registry.encode(registry.from_msgpack("sensor_msgs/TimeReference", packed)) == wire


# -- ROS 2: builtin_interfaces Time stays int32 sec, uint32 nanosec in CDR ------------------


@pytest.mark.parametrize(
    ("sec", "nanosec"), [(0, 0), (-1, 5), (INT32_MIN, 0), (INT32_MAX, UINT32_MAX)]
)
def test_ros2_time_cdr_is_int32_uint32(sec: int, nanosec: int) -> None:
    ros2 = MessageRegistry(store=Stores.ROS2_HUMBLE)
    golden = b"\x00\x01\x00\x00" + struct.pack("<iI", sec, nanosec)
    stamp = ros2.new("builtin_interfaces/Time")
    stamp.sec, stamp.nanosec = sec, nanosec
    assert ros2.encode(stamp, fmt="cdr") == golden
    decoded = ros2.decode(golden, "builtin_interfaces/Time", "cdr")
    assert (decoded.sec, decoded.nanosec) == (sec, nanosec)


def test_ros2_time_range_and_cdr_errors(registry: MessageRegistry) -> None:
    ros2 = MessageRegistry(store=Stores.ROS2_HUMBLE)
    assert ros2.from_dict("std_msgs/Header", {"stamp": {"sec": -5}}).stamp.sec == -5
    with pytest.raises(MessageError, match=r"time seconds 2147483648 out of range \[-2147483648"):
        ros2.from_dict("std_msgs/Header", {"stamp": {"sec": 2**31}})
    # A ROS 1 stamp past 2038 is valid ROS 1 but cannot travel as CDR.
    late = registry.from_dict("std_msgs/Header", {"stamp": {"secs": 2**31}})
    with pytest.raises(MessageError) as info:
        registry.encode(late, fmt="cdr")
    assert "std_msgs/Header.stamp.sec: 2147483648 is out of range for CDR time sec (int32)" in str(
        info.value
    )


def test_types_added_later_use_the_ros1_layout(fresh_registry: MessageRegistry) -> None:
    """A type registered after the registry was built still carries uint32 time secs."""
    fresh_registry.add_message("demo_msgs/Stamps", "time[] stamps\nduration[2] waits\n")
    msg = fresh_registry.from_dict(
        "demo_msgs/Stamps",
        {"stamps": [[UINT32_MAX, 1], [2**31, 0]], "waits": [-1.5, [INT32_MIN, 0]]},
    )
    golden = struct.pack("<I4I4i", 2, UINT32_MAX, 1, 2**31, 0, -2, 500_000_000, INT32_MIN, 0)
    assert fresh_registry.encode(msg) == golden
    decoded = fresh_registry.decode(golden, "demo_msgs/Stamps")
    assert [(t.sec, t.nanosec) for t in decoded.stamps] == [(UINT32_MAX, 1), (2**31, 0)]
