"""Look up the md5sum and full definition of ROS 1 message and service types."""

from __future__ import annotations

import difflib
from typing import Protocol

from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from simbridge.endpoint.backends.ros1_raw import RawMessageType, RawServiceType
from simbridge.errors import UnknownMessageTypeError

__all__ = ["Ros1TypeResolver", "TypestoreResolver"]


class Ros1TypeResolver(Protocol):
    """Turns `package/Type` names into what the ROS 1 graph needs to know."""

    def message(self, name: str) -> RawMessageType:
        """The message type `name`; raises UnknownMessageTypeError."""
        ...

    def service(self, name: str) -> RawServiceType:
        """The service type `name`; raises UnknownMessageTypeError."""
        ...


class TypestoreResolver:
    """Resolves types from a rosbags typestore (ROS 1 Noetic by default)."""

    def __init__(self, typestore: Typestore | None = None) -> None:
        self._store = typestore or get_typestore(Stores.ROS1_NOETIC)

    def message(self, name: str) -> RawMessageType:
        """The message type `name` (`package/Type`)."""
        key = _store_key(name)
        if key not in self._store.fielddefs:
            known = [_ros_name(k) for k in self._store.fielddefs]
            close = difflib.get_close_matches(name, known, n=3)
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise UnknownMessageTypeError(f"unknown message type {name!r}{hint}")
        definition, md5sum = self._store.generate_msgdef(key)
        return RawMessageType(name=name, md5sum=md5sum, definition=definition)

    def service(self, name: str) -> RawServiceType:
        """Service types are not in a rosbags typestore."""
        raise UnknownMessageTypeError(f"unknown service type {name!r}")


def _store_key(name: str) -> str:
    package, _, base = name.partition("/")
    return f"{package}/msg/{base}"


def _ros_name(key: str) -> str:
    return key.replace("/msg/", "/")
