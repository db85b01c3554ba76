"""ROS 1 actions for an in-process `Node` (local bus, or the ros1 backend's loop):
actionlib's topics through the node's publishers and subscriptions."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from simbridge.endpoint.inprocess.node import Node
from simbridge.messages import MessageRegistry
from simbridge.messages.actionlib import (
    ActionClientCore,
    ActionServerCore,
    ClientGoal,
    ServerGoal,
)

__all__ = ["ClientGoal", "NodeActionClient", "NodeActionServer", "NodeTransport", "ServerGoal"]


class NodeTransport:
    """Publishes and subscribes through a `Node` (closing the node withdraws them)."""

    def __init__(self, node: Node) -> None:
        self.node = node

    @property
    def registry(self) -> MessageRegistry:
        """The node's message registry."""
        return self.node.registry

    def advertise(self, topic: str, msg_type: str, latch: bool = False) -> Callable[[Any], None]:
        """Advertise `topic` on the node."""
        return self.node.advertise(topic, msg_type, latch=latch).publish

    def subscribe(self, topic: str, msg_type: str, callback: Callable[[Any], None]) -> None:
        """Subscribe the node to `topic`."""
        self.node.subscribe(topic, msg_type, callback)


class NodeActionServer(ActionServerCore):
    """An action server on a `Node` (see `ActionServerCore` for the callbacks)."""

    def __init__(
        self,
        node: Node,
        name: str,
        action_type: str,
        on_goal: Callable[[ServerGoal], None],
        on_cancel: Callable[[ServerGoal], None] | None = None,
        *,
        clock: Callable[[], float] = time.time,
        status_rate: float = 5.0,
    ) -> None:
        super().__init__(
            NodeTransport(node),
            name,
            action_type,
            on_goal,
            on_cancel,
            clock=clock,
            status_rate=status_rate,
        )


class NodeActionClient(ActionClientCore):
    """An action client on a `Node`: `send_goal`, `wait`, `cancel` (see `ClientGoal`)."""

    def __init__(
        self,
        node: Node,
        name: str,
        action_type: str,
        *,
        clock: Callable[[], float] = time.time,
    ) -> None:
        super().__init__(
            NodeTransport(node),
            name,
            action_type,
            clock=clock,
            client_name=node.name.strip("/") or "node",
        )
