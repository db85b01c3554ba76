"""Types with no fields in CDR: the header alone (Unity's ROS 2 serializer) and the header plus
rosidl's placeholder byte (rclpy, simbridge's connector) are both read, and each side gets
its own spelling (issue 36). Golden bytes are written out by hand; what rclpy itself does
with them is checked live in tests/ros2/test_ros2_empty_types.py."""

from __future__ import annotations

import pytest

from simbridge.errors import MessageError
from simbridge.messages import MessageRegistry, default_registry, ros2_registry
from simbridge.messages.empty import (
    CLIENT_EMPTY,
    ROS2_EMPTY,
    client_empty,
    is_empty_type,
    ros2_empty,
)

HEADER_ONLY = bytes.fromhex("00010000")
"""Unity's spelling."""
WITH_PLACEHOLDER = bytes.fromhex("0001000000")
"""rosbags' and simbridge's connector's former spelling: header and placeholder."""
RCLPY = bytes.fromhex("0001000000550000")
"""rclpy's spelling as measured (rclpy 7.1, Fast DDS): the padding holds stale bytes."""
ROS2_GOLDEN = bytes.fromhex("0001000000000000")
BIG_ENDIAN_HEADER_ONLY = bytes.fromhex("00000000")

EMPTY_TYPES = ["std_msgs/Empty", "std_srvs/EmptyRequest", "std_srvs/TriggerRequest"]
SPELLINGS = [HEADER_ONLY, WITH_PLACEHOLDER, RCLPY, ROS2_GOLDEN, BIG_ENDIAN_HEADER_ONLY]


def test_the_two_constants_are_the_golden_bytes() -> None:
    assert (ROS2_EMPTY, CLIENT_EMPTY) == (ROS2_GOLDEN, HEADER_ONLY)


@pytest.mark.parametrize("payload", SPELLINGS)
@pytest.mark.parametrize("name", [*EMPTY_TYPES, "std_srvs/EmptyResponse"])
def test_every_spelling_becomes_each_sides(name: str, payload: bytes) -> None:
    assert ros2_empty(payload, name) == ROS2_GOLDEN
    assert client_empty(bytearray(payload), name) == HEADER_ONLY
    assert client_empty(memoryview(payload), name) == HEADER_ONLY


@pytest.mark.parametrize(
    ("payload", "shown"),
    [
        (b"", "0 bytes: nothing"),
        (b"\x00\x01\x00", "3 bytes: 00 01 00"),
        (b"\x00\x07\x00\x00", "4 bytes: 00 07 00 00"),  # XCDR2, not what ROS 2 writes
        (b"\x01\x01\x00\x00\x00", "5 bytes: 01 01 00 00 00"),
    ],
)
def test_what_is_no_cdr_header_is_refused_naming_type_and_bytes(payload: bytes, shown: str) -> None:
    for respell in (ros2_empty, client_empty):
        with pytest.raises(MessageError, match=rf"malformed CDR std_msgs/Empty \({shown}\)"):
            respell(payload, "std_msgs/Empty")


def test_what_counts_as_empty() -> None:
    assert is_empty_type([])
    assert is_empty_type(["structure_needs_at_least_one_member"])
    assert not is_empty_type(["data"])
    assert not is_empty_type(["structure_needs_at_least_one_member", "data"])


@pytest.mark.parametrize("registry", [ros2_registry(), default_registry()], ids=["ROS2", "ROS1"])
@pytest.mark.parametrize("name", EMPTY_TYPES)
def test_codec_writes_ros2_spelling_and_reads_both(registry: MessageRegistry, name: str) -> None:
    codec = registry.codec(name)
    assert codec.empty
    assert registry.encode(registry.new(name), name, fmt="cdr") == ROS2_GOLDEN
    assert bytes(codec.encode_buffer(registry.new(name), "cdr")) == ROS2_GOLDEN
    for payload in SPELLINGS:
        assert registry.decode(payload, name, fmt="cdr") == registry.new(name)
        assert codec.ros2_cdr(payload) == ROS2_GOLDEN
    with pytest.raises(MessageError, match=rf"malformed CDR {name}"):
        registry.decode(b"\x00\x01", name, fmt="cdr")
    with pytest.raises(MessageError, match=rf"malformed CDR {name}"):
        codec.ros2_cdr(b"\x00\x01")


def test_constants_only_types_are_empty_too() -> None:
    registry = ros2_registry()
    assert registry.codec("rcl_interfaces/ParameterType").empty
    assert registry.decode(HEADER_ONLY, "rcl_interfaces/ParameterType", fmt="cdr") is not None


def test_types_with_fields_are_untouched() -> None:
    registry = ros2_registry()
    response = registry.codec("std_srvs/TriggerResponse")
    assert not response.empty
    wire = registry.encode(registry.new("std_srvs/TriggerResponse", success=True, message="ok"))
    assert wire == HEADER_ONLY + b"\x01\x00\x00\x00\x03\x00\x00\x00ok\x00"
    assert response.ros2_cdr(bytearray(wire)) == wire
    assert response.ros2_cdr(wire) is wire
    with pytest.raises(MessageError):
        registry.decode(HEADER_ONLY, "std_srvs/TriggerResponse", fmt="cdr")


def test_transcoding_gives_ros2_spelling_and_ros1_nothing() -> None:
    registry = ros2_registry()
    for payload in SPELLINGS:
        assert registry.transcode(payload, "std_msgs/Empty", "cdr", "cdr") == ROS2_GOLDEN
        assert registry.transcode(payload, "std_msgs/Empty", "cdr", "ros1") == b""
    assert registry.transcode(b"", "std_srvs/TriggerRequest", "ros1", "cdr") == ROS2_GOLDEN
