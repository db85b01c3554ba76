"""Message objects <-> payload bytes for the connector, through `simbridge.messages`.

Raw payloads (bytes, bytearray, memoryview) pass through untouched, so the connector
works with types no registry knows; objects are serialized as ROS 1 binary or CDR
according to the connector's protocol mode, with that generation's message layouts
(the shared ROS 1 or ROS 2 registry unless one was given).
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Any, Literal

from simbridge.errors import ConnectorError, MessageError

if TYPE_CHECKING:
    from simbridge.messages import Codec, MessageRegistry, WireFormat

__all__ = ["PayloadCodec", "RawPayload", "is_raw"]

RawPayload = bytes | bytearray | memoryview


def is_raw(value: object) -> bool:
    """True for an already-serialized payload."""
    return isinstance(value, bytes | bytearray | memoryview)


class PayloadCodec:
    """Per-type codecs looked up once and cached; the registry loads on first use."""

    def __init__(self, registry: MessageRegistry | None, protocol: Literal["ROS1", "ROS2"]) -> None:
        self._given = registry
        self._registry = registry
        self._codecs: dict[str, Codec] = {}
        self._services: dict[str, tuple[str, str]] = {}
        self._lock = threading.Lock()
        self.protocol = protocol
        self._fmt: WireFormat = "cdr" if protocol == "ROS2" else "ros1"

    def set_protocol(self, protocol: Literal["ROS1", "ROS2"]) -> None:
        """Switch serialization (and, unless a registry was given, layouts) to `protocol`."""
        with self._lock:
            self.protocol = protocol
            self._fmt = "cdr" if protocol == "ROS2" else "ros1"
            self._registry = self._given
            self._codecs, self._services = {}, {}

    @property
    def registry(self) -> MessageRegistry:
        """The registry in use: the one given, else the shared one of the protocol."""
        if self._registry is None:
            with self._lock:
                if self._registry is None:
                    from simbridge.messages import registry_for  # noqa: PLC0415 - lazy

                    self._registry = registry_for(self.protocol)
        return self._registry

    def check_type(self, type_name: str, what: str, service: bool = False) -> None:
        """ConnectorError, naming the closest known type, when `type_name` is no message (or
        service) type of the registry given or of either generation's shared registry; a
        connector checks every type it registers, so a typo fails where it is written."""
        from simbridge.messages import registry_for  # noqa: PLC0415 - lazy

        def knows(registry: MessageRegistry) -> bool:
            return registry.has_service(type_name) if service else registry.has(type_name)

        current = self.registry
        if knows(current):
            return
        if self._given is None and knows(
            registry_for("ROS2" if self.protocol == "ROS1" else "ROS1")
        ):
            return
        try:
            current.service(type_name) if service else current.resolve(type_name)
        except MessageError as exc:
            raise ConnectorError(
                f"{what}: {exc} (pass raw=True to handle payload bytes of a type only the "
                "ROS side knows)"
            ) from None

    def _codec(self, type_name: str) -> Codec:
        codec = self._codecs.get(type_name)
        if codec is None:
            codec = self._codecs[type_name] = self.registry.codec(type_name)
        return codec

    def service_parts(self, srv_type: str) -> tuple[str, str]:
        """Request and response message types of service `srv_type`."""
        parts = self._services.get(srv_type)
        if parts is None:
            info = self.registry.service(srv_type)
            parts = self._services[srv_type] = (info.request, info.response)
        return parts

    def encode(self, msg: object, type_name: str) -> bytes:
        """Payload bytes of `msg` (a raw payload is returned as immutable bytes)."""
        if isinstance(msg, bytes):
            return msg
        if isinstance(msg, bytearray | memoryview):
            return bytes(msg)
        try:
            return self._codec(type_name).encode(msg, self._fmt)
        except MessageError as exc:
            raise ConnectorError(f"cannot serialize a message for {type_name}: {exc}") from exc

    def decode(self, payload: bytes, type_name: str) -> Any:
        """The message object in `payload`; MessageError when malformed."""
        return self._codec(type_name).decode(payload, self._fmt)
