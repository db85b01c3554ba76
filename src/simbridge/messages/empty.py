"""ROS 2 types with no fields in CDR, in the two spellings clients write.

rosidl gives a type without fields (std_msgs/Empty, std_srvs/Trigger's request, a
constants-only type) one member, `uint8 structure_needs_at_least_one_member`, so ROS 2
(rclpy, Fast DDS, rosbag2) writes such a message as the encapsulation header, that byte
and padding to four bytes, and refuses the header alone. Unity's ROS-TCP-Connector in ROS
2 mode writes the header alone (its generated types have no such member) and reads any
payload of an empty type without looking past the header. Whatever hands an empty type's
CDR on spells it for its receiver: `ros2_empty` towards ROS 2 (rclpy, decoders,
recordings), `client_empty` towards a TCP client; both take either spelling.
"""

from __future__ import annotations

from collections.abc import Iterable

from simbridge.errors import MessageError

__all__ = [
    "CDR_HEADERS",
    "CLIENT_EMPTY",
    "PLACEHOLDER",
    "ROS2_EMPTY",
    "check_empty_cdr",
    "client_empty",
    "is_empty_type",
    "ros2_empty",
]

PLACEHOLDER = "structure_needs_at_least_one_member"
"""The member rosidl adds to a type without fields."""

ROS2_EMPTY = b"\x00\x01\x00\x00\x00\x00\x00\x00"
"""An empty type as rclpy writes it: little-endian header, the placeholder (0), padding
(rclpy leaves whatever its buffer held in the padding; here it is zero)."""

CLIENT_EMPTY = b"\x00\x01\x00\x00"
"""An empty type as Unity's ROS 2 serializer writes it: the header alone."""

CDR_HEADERS = (b"\x00\x00", b"\x00\x01")
"""First two bytes of a plain CDR encapsulation header: big-endian, little-endian."""


def is_empty_type(field_names: Iterable[str]) -> bool:
    """Whether a type with these fields carries no data: none, or only the placeholder."""
    return all(name == PLACEHOLDER for name in field_names)


def check_empty_cdr(payload: bytes | bytearray | memoryview, name: str) -> None:
    """MessageError unless `payload` can be CDR of the empty type `name`: it must start
    with a plain CDR encapsulation header; what follows (the placeholder, padding) carries
    nothing."""
    if len(payload) < 4 or bytes(payload[:2]) not in CDR_HEADERS:
        shown = bytes(payload[:8]).hex(" ") or "nothing"
        raise MessageError(
            f"malformed CDR {name} ({len(payload)} bytes: {shown}): expected a CDR "
            "encapsulation header (00 01 00 00, or 00 00 00 00 big-endian), alone or "
            "followed by the placeholder byte, as an empty type has no fields"
        )


def ros2_empty(payload: bytes | bytearray | memoryview, name: str) -> bytes:
    """The empty type `name` as ROS 2 reads it (ROS2_EMPTY), from either spelling."""
    check_empty_cdr(payload, name)
    return ROS2_EMPTY


def client_empty(payload: bytes | bytearray | memoryview, name: str) -> bytes:
    """The empty type `name` as a TCP client gets it (CLIENT_EMPTY), from either spelling."""
    check_empty_cdr(payload, name)
    return CLIENT_EMPTY
