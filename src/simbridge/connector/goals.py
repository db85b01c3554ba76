"""Routes the `actions` extension's frames from the endpoint to the goals waiting for them.

The reader queues each frame as a task for the dispatcher, which calls `GoalRouter.handle`
as it runs every other user callback: one at a time, in order.
"""

from __future__ import annotations

import itertools
import threading
from collections import deque
from concurrent.futures import Future
from typing import Protocol

from simbridge.connector.calls import resolve_future
from simbridge.protocol import (
    ActionFeedback,
    ActionResult,
    ActionServerReply,
    ActionStatus,
    Command,
    ErrorMessage,
)

__all__ = ["GoalRouter", "GoalSink"]


class GoalSink(Protocol):
    """What a goal sent by this connector hears about itself."""

    def goal_status(self, status: int) -> None:
        """A running status (action_msgs/GoalStatus: accepted, executing, canceling)."""

    def goal_feedback(self, payload: bytes) -> None:
        """Serialized feedback."""

    def goal_result(self, status: int, payload: bytes) -> None:
        """The terminal status and serialized result; the goal is over."""

    def goal_error(self, text: str) -> None:
        """The goal ended without a result (refused, rejected, connection lost)."""


class GoalRouter:
    """Goals in flight by goal id, and `wait_for_server` queries by action name."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._ids = itertools.count(1)
        self._goals: dict[int, GoalSink] = {}
        self._queries: dict[str, deque[Future[bool]]] = {}

    def add(self, sink: GoalSink) -> int:
        """A new goal id, routed to `sink` until its result or error."""
        with self._lock:
            goal_id = next(self._ids)
            self._goals[goal_id] = sink
            return goal_id

    def forget(self, goal_id: int) -> None:
        """Stop routing frames of `goal_id`."""
        with self._lock:
            self._goals.pop(goal_id, None)

    def expect_reply(self, action: str) -> Future[bool]:
        """A future for the next `__action_server` reply about `action`."""
        future: Future[bool] = Future()
        with self._lock:
            self._queries.setdefault(action, deque()).append(future)
        return future

    def takes(self, command: Command) -> bool:
        """Whether `command` is one of the extension's (an `__error` with a goal id too)."""
        if isinstance(command, ErrorMessage):
            return command.goal_id is not None
        return isinstance(command, ActionStatus | ActionFeedback | ActionResult | ActionServerReply)

    def handle(self, command: Command) -> None:
        """Deliver one frame (as a callback, on a connector worker)."""
        if isinstance(command, ActionServerReply):
            with self._lock:
                waiting = self._queries.get(command.action)
                future = waiting.popleft() if waiting else None
                if waiting is not None and not waiting:
                    del self._queries[command.action]
            if future is not None:
                resolve_future(future, command.ready)
            return
        goal_id = getattr(command, "goal_id", None)
        with self._lock:
            if isinstance(command, ActionResult | ErrorMessage):
                sink = self._goals.pop(goal_id, None) if isinstance(goal_id, int) else None
            else:
                sink = self._goals.get(goal_id) if isinstance(goal_id, int) else None
        if sink is None:
            return
        if isinstance(command, ActionStatus):
            sink.goal_status(command.status)
        elif isinstance(command, ActionFeedback):
            sink.goal_feedback(command.feedback)
        elif isinstance(command, ActionResult):
            sink.goal_result(command.status, command.result)
        elif isinstance(command, ErrorMessage):
            sink.goal_error(command.text)

    def lost(self, reason: str) -> None:
        """The connection is gone (the endpoint cancels what was in flight): fail everything."""
        with self._lock:
            goals, self._goals = self._goals, {}
            queries, self._queries = self._queries, {}
        for sink in goals.values():
            sink.goal_error(reason)
        for waiting in queries.values():
            for future in waiting:
                resolve_future(future, False)
