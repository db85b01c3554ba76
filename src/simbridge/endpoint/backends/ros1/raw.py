"""rospy message and service classes that carry serialized bytes as they are.

rospy only needs a class's `_type`, `_md5sum` and `_full_text` to advertise,
subscribe or serve, and calls `serialize`/`deserialize` to move bytes: a class
that copies bytes through lets the endpoint route any type it has a definition
for, with no Python message module and no decode/re-encode round trip.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import BinaryIO

import genpy

__all__ = [
    "RawMessage",
    "RawMessageType",
    "RawService",
    "RawServiceType",
    "raw_message_class",
    "raw_service_class",
]


@dataclass(frozen=True, slots=True)
class RawMessageType:
    """What the ROS 1 graph must know about a message type (`package/Type`)."""

    name: str
    md5sum: str
    definition: str


@dataclass(frozen=True, slots=True)
class RawServiceType:
    """A service type (`package/Service`) with its request and response types."""

    name: str
    md5sum: str
    request: RawMessageType
    response: RawMessageType


class RawMessage(genpy.Message):  # type: ignore[misc]
    """A message that is its serialized bytes; subclasses name the type."""

    __slots__ = ("_buff",)
    _type = ""
    _md5sum = ""
    _full_text = ""
    _has_header = False  # never let rospy rewrite header.seq inside the bytes
    _slot_types: list[str] = []

    def __init__(self, buff: bytes = b"") -> None:
        self._buff = buff

    @property
    def payload(self) -> bytes:
        """The serialized message."""
        return self._buff

    def serialize(self, buff: BinaryIO) -> None:
        """Write the bytes unchanged."""
        buff.write(self._buff)

    def deserialize(self, data: bytes) -> RawMessage:
        """Keep the received bytes unchanged."""
        self._buff = data
        return self


class RawService:
    """A service class for rospy; subclasses name the type and its raw halves."""

    _type = ""
    _md5sum = ""
    _request_class: type[RawMessage] = RawMessage
    _response_class: type[RawMessage] = RawMessage


_lock = threading.Lock()
_message_classes: dict[RawMessageType, type[RawMessage]] = {}
_service_classes: dict[RawServiceType, type[RawService]] = {}


def _class_name(type_name: str, suffix: str = "") -> str:
    return "Raw_" + type_name.replace("/", "_") + suffix


def raw_message_class(info: RawMessageType) -> type[RawMessage]:
    """The (cached) raw class for one message type."""
    with _lock:
        cls = _message_classes.get(info)
        if cls is None:
            attrs = {
                "__slots__": (),
                "_type": info.name,
                "_md5sum": info.md5sum,
                "_full_text": info.definition,
            }
            cls = type(_class_name(info.name), (RawMessage,), attrs)
            _message_classes[info] = cls
        return cls


def raw_service_class(info: RawServiceType) -> type[RawService]:
    """The (cached) raw class for one service type."""
    request = raw_message_class(info.request)
    response = raw_message_class(info.response)
    with _lock:
        cls = _service_classes.get(info)
        if cls is None:
            attrs = {
                "_type": info.name,
                "_md5sum": info.md5sum,
                "_request_class": request,
                "_response_class": response,
            }
            cls = type(_class_name(info.name, "_srv"), (RawService,), attrs)
            _service_classes[info] = cls
        return cls
