"""Binary encoding: ROS 1 and CDR round trips, hand-computed layouts, fuzzed garbage."""

from __future__ import annotations

import contextlib
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rosbags.typesys.store import Typestore

import simbridge.messages.registry as registry_module
from simbridge.errors import MessageError
from simbridge.messages import MessageRegistry
from simbridge.messages.codec import Codec

FUZZ_TYPES = [
    "geometry_msgs/Twist",
    "std_msgs/String",
    "sensor_msgs/Image",
    "sensor_msgs/JointState",
    "sensor_msgs/PointCloud2",
    "tf2_msgs/TFMessage",
    "moveit_msgs/RobotTrajectory",
    "niryo_moveit/MoverServiceRequest",
    "visualization_msgs/MarkerArray",
    "std_msgs/Empty",
]


def test_ros1_layout_by_hand(registry: MessageRegistry) -> None:
    header = registry.new("std_msgs/Header", seq=1, stamp={"secs": 2, "nsecs": 3}, frame_id="ab")
    assert registry.encode(header) == struct.pack("<IIII2s", 1, 2, 3, 2, b"ab")
    state = registry.new("sensor_msgs/JointState", name=["j"], position=[1.5])
    expected = struct.pack("<IIII", 0, 0, 0, 0)  # header with empty frame_id
    expected += struct.pack("<II1s", 1, 1, b"j") + struct.pack("<Id", 1, 1.5)
    expected += struct.pack("<II", 0, 0)  # empty velocity and effort
    assert registry.encode(state) == expected


def test_cdr_layout_by_hand(registry: MessageRegistry) -> None:
    twist = registry.new("geometry_msgs/Twist", linear={"x": 1.0})
    wire = registry.encode(twist, fmt="cdr")
    assert wire[:4] == b"\x00\x01\x00\x00"
    assert wire[4:] == struct.pack("<6d", 1.0, 0, 0, 0, 0, 0)
    string = registry.encode(registry.new("std_msgs/String", data="hi"), fmt="cdr")
    assert string == b"\x00\x01\x00\x00" + struct.pack("<I3s", 3, b"hi\x00")
    big_endian = b"\x00\x00\x00\x00" + struct.pack(">I3s", 3, b"hi\x00")
    assert registry.decode(big_endian, "std_msgs/String", "cdr").data == "hi"


@pytest.mark.parametrize("fmt", ["ros1", "cdr"])
def test_image_round_trip(registry: MessageRegistry, fmt: str) -> None:
    pixels = np.arange(640 * 480 * 3, dtype=np.uint32).astype(np.uint8)
    image = registry.new(
        "sensor_msgs/Image", height=480, width=640, encoding="rgb8", step=1920, data=pixels
    )
    wire = registry.encode(image, fmt=fmt)  # type: ignore[arg-type]
    decoded = registry.decode(wire, "sensor_msgs/Image", fmt)  # type: ignore[arg-type]
    assert decoded.encoding == "rgb8"
    assert np.array_equal(decoded.data, pixels)
    codec = registry.codec("sensor_msgs/Image")
    assert bytes(codec.encode_buffer(image, fmt)) == wire  # type: ignore[arg-type]


def test_transcode(registry: MessageRegistry) -> None:
    state = registry.new("sensor_msgs/JointState", name=["a", "bc"], position=[1.0, 2.0])
    ros1 = registry.encode(state)
    cdr = registry.transcode(ros1, "sensor_msgs/JointState", "ros1", "cdr")
    assert cdr == registry.encode(state, fmt="cdr")
    assert registry.transcode(cdr, "sensor_msgs/JointState", "cdr", "ros1") == ros1
    assert registry.transcode(ros1, "sensor_msgs/JointState", "ros1", "ros1") == ros1


def test_decoding_a_mutable_buffer_does_not_alias_it(registry: MessageRegistry) -> None:
    buffer = bytearray(registry.encode(registry.new("sensor_msgs/Image", data=b"\x05")))
    image = registry.decode(buffer, "sensor_msgs/Image")
    buffer[-1] = 9
    assert image.data.tolist() == [5]


def test_encode_errors_are_message_errors(registry: MessageRegistry) -> None:
    twist = registry.new("geometry_msgs/Twist")
    twist.linear.x = "fast"
    with pytest.raises(
        MessageError,
        match=r"cannot encode geometry_msgs/Twist as ROS 1: geometry_msgs/Twist\.linear\.x: "
        r"expected a number \(float64\), got 'fast'",
    ):
        registry.encode(twist)
    image = registry.new("sensor_msgs/Image")
    image.data = [1, 2, 3]
    with pytest.raises(
        MessageError, match=r"Image\.data: expected a numpy array of uint8, got list"
    ):
        registry.encode(image)
    with pytest.raises(MessageError, match="expected a geometry_msgs/Twist message, got"):
        registry.encode(registry.new("std_msgs/String"), "geometry_msgs/Twist")
    with pytest.raises(MessageError, match="not a message object"):
        registry.encode(b"raw")
    with pytest.raises(MessageError, match="unknown wire format 'json'"):
        registry.encode(twist, fmt="json")  # type: ignore[arg-type]


def test_truncated_and_trailing_bytes(registry: MessageRegistry) -> None:
    wire = registry.encode(registry.new("std_msgs/Header", frame_id="map"))
    with pytest.raises(MessageError, match="malformed ROS 1 std_msgs/Header"):
        registry.decode(wire[:-1], "std_msgs/Header")
    with pytest.raises(MessageError, match="1 trailing byte"):
        registry.decode(wire + b"\x00", "std_msgs/Header")
    with pytest.raises(MessageError, match="encapsulation header"):
        registry.decode(b"\x00\x07\x00\x00", "std_msgs/Header", "cdr")
    for fmt in ("ros1", "cdr"):
        with pytest.raises(MessageError):
            registry.decode("text", "std_msgs/Header", fmt)  # type: ignore[arg-type]
    huge = struct.pack("<IIII", 0, 0, 0, 0xFFFFFFFF)
    with pytest.raises(MessageError):
        registry.decode(huge, "std_msgs/Header")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    name=st.sampled_from(FUZZ_TYPES),
    data=st.binary(max_size=256),
    fmt=st.sampled_from(["ros1", "cdr"]),
)
def test_garbage_raises_only_message_error(
    registry: MessageRegistry, name: str, data: bytes, fmt: str
) -> None:
    try:
        msg = registry.decode(data, name, fmt)  # type: ignore[arg-type]
    except MessageError:
        return
    assert registry.decode(registry.encode(msg, fmt=fmt), name, fmt) is not None  # type: ignore[arg-type]


@settings(max_examples=200, deadline=None)
@given(
    name=st.sampled_from(FUZZ_TYPES),
    flips=st.lists(st.tuples(st.integers(0, 10_000), st.integers(1, 255)), max_size=6),
    cut=st.integers(0, 64),
    fmt=st.sampled_from(["ros1", "cdr"]),
)
def test_corrupted_valid_messages_raise_only_message_error(
    registry: MessageRegistry, name: str, flips: list[tuple[int, int]], cut: int, fmt: str
) -> None:
    wire = bytearray(registry.encode(registry.new(name), fmt=fmt))  # type: ignore[arg-type]
    for position, mask in flips:
        if wire:
            wire[position % len(wire)] ^= mask
    del wire[len(wire) - min(cut, len(wire)) :]
    with contextlib.suppress(MessageError):
        registry.decode(bytes(wire), name, fmt)  # type: ignore[arg-type]


finite = st.floats(allow_nan=False, width=64)


@settings(max_examples=100, deadline=None)
@given(values=st.lists(finite, min_size=6, max_size=6), fmt=st.sampled_from(["ros1", "cdr"]))
def test_twist_round_trip(registry: MessageRegistry, values: list[float], fmt: str) -> None:
    twist = registry.from_dict("geometry_msgs/Twist", [values[:3], values[3:]])
    decoded = registry.decode(registry.encode(twist, fmt=fmt), "geometry_msgs/Twist", fmt)  # type: ignore[arg-type]
    assert decoded == twist


def test_messages_cross_registries_with_the_same_type() -> None:
    first, second = MessageRegistry(shipped=False), MessageRegistry(shipped=False)
    for reg in (first, second):
        reg.add_message("demo_msgs/Pair", "int32 a\nstring b\n")
    pair = first.new("demo_msgs/Pair", a=-7, b="x")
    assert type(pair) is not second.msg_class("demo_msgs/Pair")
    assert second.encode(pair) == struct.pack("<iI1s", -7, 1, b"x")


def test_hot_path_codec_is_built_once_and_reused(
    registry: MessageRegistry, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The cached fast path (its speed is benchmarked, not asserted here): every spelling
    of a type gets the one codec built at its first use, and encoding and decoding through
    it never resolve the type or build a codec again."""
    codec = registry.codec("geometry_msgs/Twist")
    twist = registry.new("geometry_msgs/Twist", linear={"x": 0.5})
    built: list[str] = []
    resolved: list[str] = []

    class CountingCodec(Codec):
        def __init__(self, typestore: Typestore, store_key: str, name: str) -> None:
            built.append(name)
            super().__init__(typestore, store_key, name)

    real_resolve = registry.resolve

    def resolve(name: str) -> str:
        resolved.append(name)
        return real_resolve(name)

    monkeypatch.setattr(registry_module, "Codec", CountingCodec)
    monkeypatch.setattr(registry, "resolve", resolve)
    for _ in range(1000):
        assert registry.codec("geometry_msgs/Twist") is codec
        assert codec.decode(codec.encode(twist)).linear.x == 0.5
    assert registry.codec("geometry_msgs/msg/Twist") is codec  # another spelling: resolved once
    assert registry.codec("geometry_msgs/msg/Twist") is codec
    assert built == []
    assert resolved in ([], ["geometry_msgs/msg/Twist"])  # [] if an earlier test used it


def test_ros2_store_gives_ros2_layouts() -> None:
    from rosbags.typesys import Stores

    ros2 = MessageRegistry(store=Stores.ROS2_HUMBLE)
    header = ros2.new("std_msgs/Header", stamp={"secs": 1, "nsecs": 2}, frame_id="a")
    assert ros2.encode(header, fmt="cdr") == b"\x00\x01\x00\x00" + struct.pack(
        "<iII2s", 1, 2, 2, b"a\x00"
    )  # no seq in ROS 2
    assert ros2.has("moveit_msgs/RobotTrajectory")  # shipped packages with satisfied deps
    assert ros2.has_service("niryo_moveit/MoverService")
    assert not ros2.has("roscpp/GetLoggersRequest")  # needs roscpp/Logger, noetic-only
    assert MessageRegistry(store=Stores.EMPTY, shipped=False).names() == []
