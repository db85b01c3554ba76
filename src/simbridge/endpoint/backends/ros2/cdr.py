"""CDR between the endpoint's TCP clients and rclpy, each side getting its own spelling of an
empty type (`simbridge.messages.empty`).

rclpy refuses an empty type's CDR without rosidl's placeholder byte, which is how Unity
writes it, and writes the placeholder plus padding whose bytes are whatever its buffer
held; clients get the header alone, which Unity's deserializer and simbridge's codecs read.
Every other type passes through unchanged.
"""

from __future__ import annotations

from typing import Any

from rclpy.serialization import deserialize_message, serialize_message

from simbridge.messages.empty import CLIENT_EMPTY, ros2_empty

__all__ = ["from_client", "interface_name", "is_empty_interface", "ros2_payload", "to_client"]


def interface_name(cls: Any) -> str:
    """`pkg/Type` of an rclpy interface class (a service part: `pkg/Srv_Request`)."""
    return f"{cls.__module__.split('.')[0]}/{cls.__name__}"


def is_empty_interface(cls: Any) -> bool:
    """Whether rclpy message class `cls` has no fields (rclpy hides the placeholder)."""
    return not cls.get_fields_and_field_types()


def ros2_payload(cls: Any, payload: bytes | bytearray) -> bytes | bytearray:
    """A client's CDR of `cls` as rclpy reads it: unchanged, an empty type in ROS 2's
    spelling (MessageError when its header is not CDR's)."""
    if is_empty_interface(cls):
        return ros2_empty(payload, interface_name(cls))
    return payload


def from_client(payload: bytes | bytearray, cls: Any) -> Any:
    """The rclpy message of class `cls` in a client's CDR `payload` (either spelling of an
    empty type); raises when the payload is not one."""
    return deserialize_message(ros2_payload(cls, payload), cls)


def to_client(msg: Any) -> bytes:
    """CDR of rclpy message `msg` for a client (an empty type as the header alone)."""
    if is_empty_interface(type(msg)):
        return CLIENT_EMPTY
    return bytes(serialize_message(msg))
