"""Routes the `action_servers` extension's requests from the endpoint to the connector's
served actions, and keeps the registrations replayed on every new connection.

The reader queues each request as a task for the dispatcher, which calls
`ServedRouter.handle` as it runs every other user callback: one at a time, in order.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Protocol

from simbridge.protocol import (
    Command,
    ServeAction,
    ServedAccept,
    ServedCancelRequest,
    ServedGoalRequest,
)

__all__ = ["ServedHandler", "ServedRouter"]


class ServedHandler(Protocol):
    """What an action served through the connector hears about its goals."""

    @property
    def action_type(self) -> str:
        """The action's type, `pkg/Action`."""
        ...

    def goal_requested(self, goal_id: int, payload: bytes) -> None:
        """A ROS 2 client's goal (CDR); answer with `__action_accept`."""

    def cancel_requested(self, goal_id: int) -> None:
        """A ROS 2 client asked to cancel a goal (ignore ids that are not yours)."""

    def connection_lost(self) -> None:
        """The endpoint aborted every goal: forget them."""


class ServedRouter:
    """The connector's served actions by name."""

    def __init__(self, reply: Callable[[Command], None]) -> None:
        self._lock = threading.Lock()
        self._servers: dict[str, ServedHandler] = {}
        self._reply = reply
        """Sends a command to the endpoint (a refusal for a goal of an action not served)."""

    def add(self, action: str, handler: ServedHandler) -> None:
        """Serve `action` with `handler` (replacing any handler it had)."""
        with self._lock:
            self._servers[action] = handler

    def remove(self, action: str, handler: ServedHandler) -> bool:
        """Stop routing `action` to `handler`; whether it was routed there."""
        with self._lock:
            if self._servers.get(action) is not handler:
                return False
            del self._servers[action]
            return True

    def registrations(self) -> list[ServeAction]:
        """`__action_serve` for every served action (sent after each handshake)."""
        with self._lock:
            return [ServeAction(name, h.action_type) for name, h in self._servers.items()]

    def takes(self, command: Command) -> bool:
        """Whether `command` is one of the extension's endpoint commands."""
        return isinstance(command, ServedGoalRequest | ServedCancelRequest)

    def handle(self, command: Command) -> None:
        """Deliver one request (as a callback, on a connector worker)."""
        with self._lock:
            handlers = list(self._servers.values())
            target = (
                self._servers.get(command.action)
                if isinstance(command, ServedGoalRequest)
                else None
            )
        if isinstance(command, ServedGoalRequest):
            if target is None:  # unserved meanwhile
                self._reply(ServedAccept(command.goal_id, False))
            else:
                target.goal_requested(command.goal_id, command.goal)
        elif isinstance(command, ServedCancelRequest):
            for handler in handlers:
                handler.cancel_requested(command.goal_id)

    def lost(self) -> None:
        """The connection is gone: the endpoint aborted every served goal."""
        with self._lock:
            handlers = list(self._servers.values())
        for handler in handlers:
            handler.connection_lost()
