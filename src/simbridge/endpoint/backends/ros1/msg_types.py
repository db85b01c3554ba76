"""What rospy must know about a type (md5sum, full definition), from the message registry."""

from __future__ import annotations

from simbridge.endpoint.backends.ros1.raw import RawMessageType, RawServiceType
from simbridge.messages import MessageRegistry

__all__ = ["Ros1Types"]


class Ros1Types:
    """Describes message and service types for raw rospy classes; no Python module needed."""

    def __init__(self, registry: MessageRegistry) -> None:
        self._registry = registry

    def message(self, name: str) -> RawMessageType:
        """The message type `name` (`pkg/Type`); UnknownMessageTypeError names close matches."""
        canonical = self._registry.resolve(name)
        return RawMessageType(
            name=canonical,
            md5sum=self._registry.md5(canonical),
            definition=self._registry.definition(canonical),
        )

    def service(self, name: str) -> RawServiceType:
        """The service type `name` (`pkg/Srv`) with its request and response types."""
        info = self._registry.service(name)
        return RawServiceType(
            name=info.name,
            md5sum=info.md5,
            request=self.message(info.request),
            response=self.message(info.response),
        )
