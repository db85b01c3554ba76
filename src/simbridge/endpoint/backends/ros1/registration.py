"""What a ROS 1 backend registered with the master and must undo on close, once."""

from __future__ import annotations

import abc

from simbridge.endpoint.backends.base import BackendPublisher

__all__ = ["Registration", "Ros1Publisher"]


class Registration(abc.ABC):
    """A publisher, subscription or service held in `live` until closed.

    `topic` and `msg_type` name a topic registration (empty for services), so a
    backend can refuse a second type on one topic.
    """

    topic: str = ""
    msg_type: str = ""

    def __init__(self, live: set[Registration]) -> None:
        self._live = live
        self._closed = False
        live.add(self)

    @property
    def closed(self) -> bool:
        return self._closed

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._live.discard(self)
            self._unregister()

    @abc.abstractmethod
    def _unregister(self) -> None:
        """Undo the registration."""


class Ros1Publisher(Registration, BackendPublisher):
    """A topic the endpoint publishes in a ROS 1 graph (through rospy or its own TCPROS)."""

    @abc.abstractmethod
    def subscriber_count(self) -> int:
        """How many subscribers are connected now (messages before the first one are lost)."""
