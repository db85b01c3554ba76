"""Per-type binary codecs (ROS 1 and CDR) built once from rosbags' generated functions."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

from simbridge.errors import MessageError

from .diagnose import find_unencodable
from .empty import CDR_HEADERS, ROS2_EMPTY, is_empty_type, ros2_empty
from .schema import canonical_of

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = ["Codec", "WireFormat"]

WireFormat = Literal["ros1", "cdr"]
"""`ros1`: ROS 1 binary; `cdr`: ROS 2 CDR with its 4-byte encapsulation header."""

_CDR_LE = b"\x00\x01\x00\x00"
_ENCODE_HINT = "(numeric arrays must be numpy arrays; MessageRegistry.new/from_dict convert lists)"


class Codec:
    """Encodes and decodes one message type; the hot path is a few direct calls.

    A type without fields (`empty`) is written in CDR as ROS 2 writes it, and read from
    that or from the header alone, as Unity writes it (`simbridge.messages.empty`).
    """

    __slots__ = (
        "_cls",
        "_de_cdr_be",
        "_de_cdr_le",
        "_de_ros1",
        "_fixed_cdr",
        "_fixed_ros1",
        "_getsize_cdr",
        "_getsize_ros1",
        "_key",
        "_ser_cdr",
        "_ser_ros1",
        "_store",
        "empty",
        "name",
    )

    def __init__(self, typestore: Typestore, store_key: str, name: str) -> None:
        msgdef = typestore.get_msgdef(store_key)
        self.name = name
        self._key = store_key
        self._store = typestore
        self._cls = msgdef.cls
        self._fixed_ros1 = msgdef.size_ros1
        self._getsize_ros1 = msgdef.getsize_ros1
        self._ser_ros1 = msgdef.serialize_ros1
        self._de_ros1 = msgdef.deserialize_ros1
        self._fixed_cdr = msgdef.size_cdr
        self._getsize_cdr = msgdef.getsize_cdr
        self._ser_cdr = msgdef.serialize_cdr_le
        self._de_cdr_le = msgdef.deserialize_cdr_le
        self._de_cdr_be = msgdef.deserialize_cdr_be
        self.empty = is_empty_type(field for field, _desc in msgdef.fields)
        """The type carries no data (no fields, or only rosidl's placeholder)."""

    def encode(self, msg: object, fmt: WireFormat = "ros1") -> bytes:
        """Serialize `msg`; MessageError when a field holds a value its type cannot carry."""
        if fmt == "ros1":
            return bytes(self.ros1_buffer(msg))
        if fmt == "cdr":
            return bytes(self.cdr_buffer(msg))
        raise MessageError(_bad_format(fmt))

    def encode_buffer(self, msg: object, fmt: WireFormat = "ros1") -> bytearray:
        """Like encode, but hands over the freshly written buffer instead of copying it
        into bytes (saves a copy of every large message, e.g. images)."""
        if fmt == "ros1":
            return self.ros1_buffer(msg)
        if fmt == "cdr":
            return self.cdr_buffer(msg)
        raise MessageError(_bad_format(fmt))

    def decode(self, data: bytes | bytearray | memoryview, fmt: WireFormat = "ros1") -> Any:
        """Deserialize one message; any malformed input raises MessageError."""
        if fmt == "ros1":
            return self.decode_ros1(data)
        if fmt == "cdr":
            return self.decode_cdr(data)
        raise MessageError(_bad_format(fmt))

    def ros1_buffer(self, msg: object) -> bytearray:
        """Serialize to ROS 1 binary."""
        self._check_type(msg)
        try:
            size = self._fixed_ros1 or self._getsize_ros1(0, msg, self._store)
            buf = bytearray(size)
            self._ser_ros1(memoryview(buf), 0, msg, self._store)
        except Exception as exc:
            raise MessageError(self._encode_error("ros1", msg, exc)) from exc
        return buf

    def decode_ros1(self, data: bytes | bytearray | memoryview) -> Any:
        """Deserialize ROS 1 binary; the whole buffer must be consumed.

        Numeric arrays in the result are read-only views of the input bytes.
        """
        try:
            msg, pos = self._de_ros1(_frozen(data), 0, self._cls, self._store)
        except Exception as exc:
            raise MessageError(f"malformed ROS 1 {self.name} ({len(data)} bytes): {exc}") from exc
        if pos != len(data):
            msg_ = f"malformed ROS 1 {self.name}: {len(data) - pos} trailing byte(s)"
            raise MessageError(msg_)
        return msg

    def cdr_buffer(self, msg: object) -> bytearray:
        """Serialize to little-endian CDR with encapsulation header."""
        self._check_type(msg)
        if self.empty:
            return bytearray(ROS2_EMPTY)
        try:
            size = self._fixed_cdr or self._getsize_cdr(0, msg, self._store)
            buf = bytearray(4 + size)
            buf[:4] = _CDR_LE
            self._ser_cdr(memoryview(buf)[4:], 0, msg, self._store)
        except Exception as exc:
            raise MessageError(self._encode_error("cdr", msg, exc)) from exc
        return buf

    def decode_cdr(self, data: bytes | bytearray | memoryview) -> Any:
        """Deserialize CDR (either byte order); bytes after the message are ignored.

        rmw sizes a serialized message by an upper bound, so CDR from rclpy can end in
        bytes that belong to no field (12 after a niryo_moveit/MoverService response
        holding one trajectory point, measured with rclpy 7.1 / Fast DDS): only the
        decoded values count, never the length.
        """
        try:
            raw = _frozen(data)
        except TypeError as exc:
            raise MessageError(f"cannot decode {type(data).__name__} as CDR {self.name}") from exc
        if len(raw) < 4 or raw[:2] not in CDR_HEADERS:
            msg_ = f"malformed CDR {self.name}: missing or unknown encapsulation header"
            raise MessageError(msg_)
        if self.empty:
            raw = ROS2_EMPTY  # the header alone (Unity) is a whole message too
        func = self._de_cdr_le if raw[1] else self._de_cdr_be
        try:
            msg, _end = func(memoryview(raw)[4:], 0, self._cls, self._store)
        except Exception as exc:
            raise MessageError(f"malformed CDR {self.name} ({len(data)} bytes): {exc}") from exc
        return msg

    def ros2_cdr(self, data: bytes | bytearray | memoryview) -> bytes:
        """CDR `data` as ROS 2 reads it: unchanged, except that an empty type comes in
        ROS 2's spelling from either (its header is checked; nothing else is decoded)."""
        if self.empty:
            return ros2_empty(data, self.name)
        return data if type(data) is bytes else bytes(data)

    def _encode_error(self, fmt: WireFormat, msg: object, exc: Exception) -> str:
        """Name the offending field, value and accepted range where it can be found."""
        shown = "ROS 1" if fmt == "ros1" else "CDR"
        try:
            problem = find_unencodable(self._store, self._key, msg, fmt, self.name)
        except Exception:  # a diagnosis must never hide the original error
            problem = None
        if problem is None:
            return f"cannot encode {self.name} as {shown}: {exc} {_ENCODE_HINT}"
        return f"cannot encode {self.name} as {shown}: {problem}"

    def _check_type(self, msg: object) -> None:
        # Same-named classes from another registry have the same layout: accept them.
        if type(msg) is not self._cls and getattr(msg, "__msgtype__", None) != self._key:
            got = getattr(msg, "__msgtype__", None)
            shown = canonical_of(got) if isinstance(got, str) else type(msg).__name__
            raise MessageError(f"expected a {self.name} message, got {shown}")


def _frozen(data: bytes | bytearray | memoryview) -> bytes:
    """Decoded numpy arrays view the input, so never let them alias a mutable buffer."""
    return data if type(data) is bytes else bytes(data)


def _bad_format(fmt: object) -> str:
    return f"unknown wire format {fmt!r}; valid formats: 'ros1', 'cdr'"
