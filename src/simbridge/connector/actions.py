"""ROS 1 actions through a connector: actionlib's five topics (goal, cancel, status,
feedback, result), so they work through any ROS-TCP endpoint, the original one included."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from simbridge.connector.connector import Connector
from simbridge.messages import MessageRegistry
from simbridge.messages.actionlib import (
    ActionClientCore,
    ActionServerCore,
    ClientGoal,
    ServerGoal,
)

__all__ = ["ActionClient", "ActionServer", "ClientGoal", "ConnectorTransport", "ServerGoal"]


class ConnectorTransport:
    """Publishes and subscribes through a connector; `close` withdraws what it registered."""

    def __init__(self, connector: Connector) -> None:
        self.connector = connector
        self._topics: list[tuple[str, bool]] = []

    @property
    def registry(self) -> MessageRegistry:
        """The connector's message registry."""
        return self.connector.registry

    def advertise(self, topic: str, msg_type: str, latch: bool = False) -> Callable[[Any], None]:
        """Register a publisher on `topic`."""
        pub = self.connector.register_publisher(topic, msg_type, queue_size=50, latch=latch)
        self._topics.append((topic, True))
        return pub.publish

    def subscribe(self, topic: str, msg_type: str, callback: Callable[[Any], None]) -> None:
        """Subscribe `callback` to `topic`."""
        self.connector.subscribe(topic, msg_type, callback, queue_size=100)
        self._topics.append((topic, False))

    def close(self) -> None:
        """Unregister every topic registered here."""
        for topic, published in self._topics:
            if published:
                self.connector.unregister_publisher(topic)
            else:
                self.connector.unsubscribe(topic)
        self._topics.clear()


class ActionServer(ActionServerCore):
    """An action server on a connector (see `ActionServerCore` for the callbacks)."""

    def __init__(
        self,
        connector: Connector,
        name: str,
        action_type: str,
        on_goal: Callable[[ServerGoal], None],
        on_cancel: Callable[[ServerGoal], None] | None = None,
        *,
        clock: Callable[[], float] = time.time,
        status_rate: float = 5.0,
    ) -> None:
        self.transport = ConnectorTransport(connector)
        super().__init__(
            self.transport,
            name,
            action_type,
            on_goal,
            on_cancel,
            clock=clock,
            status_rate=status_rate,
        )

    def close(self) -> None:
        """Stop and unregister the action's topics."""
        super().close()
        self.transport.close()


class ActionClient(ActionClientCore):
    """An action client on a connector: `send_goal`, `wait`, `cancel` (see `ClientGoal`)."""

    def __init__(
        self,
        connector: Connector,
        name: str,
        action_type: str,
        *,
        clock: Callable[[], float] = time.time,
        client_name: str = "simbridge",
    ) -> None:
        self.transport = ConnectorTransport(connector)
        super().__init__(self.transport, name, action_type, clock=clock, client_name=client_name)

    def close(self) -> None:
        """Unregister the action's topics."""
        self.transport.close()
