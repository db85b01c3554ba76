"""ROS 1 actions through a connector: actionlib's five topics (goal, cancel, status,
feedback, result), so they work through any ROS-TCP endpoint, the original one included."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from simbridge.connector.connector import Connector
from simbridge.connector.handles import Publisher
from simbridge.messages import MessageRegistry
from simbridge.messages.actionlib import (
    ActionClientCore,
    ActionServerCore,
    ClientGoal,
    ServerGoal,
)

__all__ = ["ActionClient", "ActionServer", "ClientGoal", "ConnectorTransport", "ServerGoal"]


class ConnectorTransport:
    """Publishes and subscribes through a connector; `close` withdraws what it registered.

    With `report_subscribers`, its publishers ask the endpoint for their subscriber counts
    (`Publisher.subscriber_count`, kept in `publishers` by topic).
    """

    def __init__(self, connector: Connector, *, report_subscribers: bool = False) -> None:
        self.connector = connector
        self.report_subscribers = report_subscribers
        self.publishers: dict[str, Publisher] = {}
        self._topics: list[tuple[str, bool]] = []

    @property
    def registry(self) -> MessageRegistry:
        """The connector's message registry."""
        return self.connector.registry

    def advertise(self, topic: str, msg_type: str, latch: bool = False) -> Callable[[Any], None]:
        """Register a publisher on `topic`."""
        pub = self.connector.register_publisher(
            topic,
            msg_type,
            queue_size=50,
            latch=latch,
            report_subscribers=self.report_subscribers,
        )
        self.publishers[topic] = pub
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
        self.publishers.clear()


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
        self.transport = ConnectorTransport(connector, report_subscribers=True)
        super().__init__(self.transport, name, action_type, clock=clock, client_name=client_name)

    def wait_for_server(self, timeout: float | None = None) -> bool:
        """True once the server's status was heard from and its goal and cancel
        subscribers are connected, as actionlib's SimpleActionClient decides: a goal sent
        before the server's subscriber connected would be lost (ROS 1 keeps none).

        The subscribers are known from an endpoint with the simbridge `subscribers`
        extension; with an endpoint without it (Unity's), or a graph that cannot tell,
        the status alone decides. False when `timeout` seconds pass first.
        """
        deadline = None if timeout is None else time.monotonic() + timeout
        if not super().wait_for_server(timeout):
            return False
        pubs = [self.transport.publishers.get(f"{self.name}/{t}") for t in ("goal", "cancel")]
        while not all(self._subscribed(pub) for pub in pubs):
            left = 0.01 if deadline is None else min(0.01, deadline - time.monotonic())
            if left <= 0:
                return False
            time.sleep(left)
        return True

    def _subscribed(self, pub: Publisher | None) -> bool:
        """Whether `pub` may be published on without its message being lost."""
        if pub is None or pub.closed:
            return False
        count = pub.subscriber_count
        if count is None:  # not told yet, or never will be: the endpoint lacks the extension
            return "subscribers" not in self.transport.connector.extensions
        return count != 0  # -1: the endpoint's graph cannot tell

    def close(self) -> None:
        """Unregister the action's topics."""
        self.transport.close()
