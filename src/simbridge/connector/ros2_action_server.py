"""ROS 2 action servers through a connector, over the endpoint's `action_servers` extension.

`Ros2ActionServer` has the API of the ROS 1 `ActionServer` (actionlib topics): `on_goal`
gets each goal, `on_cancel` each cancel request, and the goal moves through actionlib's
states with `accept`, `reject`, `succeed`, `abort`, `canceled` and `publish_feedback`, so
code written for one serves the other; `action_server` picks the right one. On ROS 2 a
rejection carrying a result (an error code) is sent as accepted then aborted, so the ROS 2
client gets the code (a ROS 2 rejection has no result); `canceled` on a running goal
without a cancel request is a preemption, canceled on the ROS 2 side too.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

from simbridge.connector.actions import ActionServer
from simbridge.connector.connector import Connector
from simbridge.errors import ConnectorError, MessageError
from simbridge.messages.actionlib import (
    ABORTED,
    ACTIVE,
    PENDING,
    PREEMPTED,
    PREEMPTING,
    RECALLED,
    RECALLING,
    REJECTED,
    SUCCEEDED,
    TERMINAL,
    ServerGoal,
)
from simbridge.protocol import (
    ACTION_SERVERS_EXTENSION,
    STATUS_ABORTED,
    STATUS_CANCELED,
    STATUS_SUCCEEDED,
    ServedAccept,
    ServedFeedback,
    ServedResult,
)

__all__ = ["AnyServerGoal", "Ros2ActionServer", "Ros2ServerGoal", "action_server"]

_log = logging.getLogger("simbridge.connector")


class Ros2ServerGoal:
    """One goal a ROS 2 client sent to a `Ros2ActionServer`; `status` in actionlib's terms."""

    def __init__(self, server: Ros2ActionServer, goal_id: int, stamp: float, goal: Any) -> None:
        self.server, self.id, self.stamp, self.goal = server, goal_id, stamp, goal
        self.status = PENDING
        self.text = ""
        self.ended_at: float | None = None
        self.lost = False
        """The connection went away: the endpoint aborted the goal; every call is a no-op."""

    @property
    def cancel_requested(self) -> bool:
        """True once a cancel request reached this goal (RECALLING or PREEMPTING)."""
        return self.status in (RECALLING, PREEMPTING)

    def _move(self, allowed: dict[int, int], what: str, text: str) -> bool:
        """The transition (MessageError when not allowed); False for a lost goal."""
        with self.server.lock:
            if self.lost:
                _log.debug(
                    "%s goal %d: %s after the connection was lost", self.server.name, self.id, what
                )
                return False
            if self.status not in allowed:
                raise MessageError(
                    f"action {self.server.name!r} goal {self.id}: cannot {what} in status "
                    f"{self.status}"
                )
            self.status, self.text = allowed[self.status], text
            if self.status in TERMINAL:
                self.ended_at = time.monotonic()
                self.server.goals.pop(self.id, None)
        return True

    def accept(self, text: str = "") -> None:
        """PENDING -> ACTIVE (RECALLING -> PREEMPTING: the cancel still stands)."""
        if self._move({PENDING: ACTIVE, RECALLING: PREEMPTING}, "accept", text):
            self.server.send(ServedAccept(self.id, True))

    def reject(self, result: Any = None, text: str = "") -> None:
        """Refuse a goal not yet accepted (with a result: accepted, then aborted with it)."""
        if not self._move({PENDING: REJECTED, RECALLING: REJECTED}, "reject", text):
            return
        if result is None:
            self.server.send(ServedAccept(self.id, False))
        else:
            self.server.send(ServedAccept(self.id, True))
            self.server.send(ServedResult(self.id, STATUS_ABORTED, self.server.encode(result)))

    def succeed(self, result: Any = None, text: str = "") -> None:
        """The goal was reached."""
        if self._move({ACTIVE: SUCCEEDED, PREEMPTING: SUCCEEDED}, "succeed", text):
            self._end(STATUS_SUCCEEDED, result)

    def abort(self, result: Any = None, text: str = "") -> None:
        """The goal failed."""
        if self._move({ACTIVE: ABORTED, PREEMPTING: ABORTED}, "abort", text):
            self._end(STATUS_ABORTED, result)

    def canceled(self, result: Any = None, text: str = "") -> None:
        """Stopped on request or by preemption: RECALLED (rejected on ROS 2) before
        acceptance, else PREEMPTED (canceled)."""
        allowed = {PENDING: RECALLED, RECALLING: RECALLED, ACTIVE: PREEMPTED, PREEMPTING: PREEMPTED}
        before = self.status
        if not self._move(allowed, "cancel", text):
            return
        if before in (PENDING, RECALLING):
            self.server.send(ServedAccept(self.id, False))
        else:
            self._end(STATUS_CANCELED, result)

    def publish_feedback(self, feedback: Any) -> None:
        """Send feedback for this goal (while it runs)."""
        if not self.lost and self.status in (ACTIVE, PREEMPTING):
            self.server.send(ServedFeedback(self.id, self.server.encode(feedback, "Feedback")))

    def _end(self, status: int, result: Any) -> None:
        self.server.send(ServedResult(self.id, status, self.server.encode(result)))


AnyServerGoal = ServerGoal | Ros2ServerGoal
"""A goal of either action server (ROS 1 actionlib topics or ROS 2 through the endpoint)."""


class Ros2ActionServer:
    """Serves the ROS 2 action `name` of type `action_type` through a ROS 2 endpoint.

    `on_goal(goal)` runs for every new goal (PENDING; it accepts or rejects, now or later),
    `on_cancel(goal)` when a ROS 2 client asks to cancel one (without it, the goal is
    canceled at once); both as the connector's callbacks, one at a time. The connector's
    registry must know the action (`<Action>Goal`, `Result`, `Feedback`).
    """

    def __init__(
        self,
        connector: Connector,
        name: str,
        action_type: str,
        on_goal: Callable[[Ros2ServerGoal], None],
        on_cancel: Callable[[Ros2ServerGoal], None] | None = None,
        *,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.connector = connector
        self.name = name.rstrip("/") or name
        self._action_type = action_type
        self.on_goal, self.on_cancel, self.clock = on_goal, on_cancel, clock
        self.goals: dict[int, Ros2ServerGoal] = {}
        self.lock = threading.RLock()
        for part in ("Goal", "Result", "Feedback"):
            connector.registry.msg_class(f"{action_type}{part}")  # unknown: a clear error now
        if connector.connected and ACTION_SERVERS_EXTENSION not in connector.extensions:
            raise ConnectorError(
                f"the endpoint at {connector.host}:{connector.port} cannot host ROS 2 action "
                f"servers (it announced {sorted(connector.extensions) or 'none'} as extensions; "
                "simbridge's `--backend ros2` endpoint can); for actionlib over topics use "
                "simbridge.connector.ActionServer"
            )
        connector.serve_action(self.name, self)

    @property
    def action_type(self) -> str:
        """The action's type, `pkg/Action`."""
        return self._action_type

    def encode(self, message: Any, part: str = "Result") -> bytes:
        """CDR of a Result (a default one for None) or Feedback message."""
        name = f"{self._action_type}{part}"
        registry = self.connector.registry
        return registry.encode(
            message if message is not None else registry.new(name), name, fmt="cdr"
        )

    def send(self, command: ServedAccept | ServedFeedback | ServedResult) -> None:
        """To the endpoint (dropped while not connected: it aborted the goals then)."""
        self.connector.send_served(command)

    # ---- ServedHandler (connector callbacks) ----------------------------------------------

    def goal_requested(self, goal_id: int, payload: bytes) -> None:
        """A new goal: decoded and handed to `on_goal` (refused when it does not decode)."""
        try:
            message = self.connector.registry.decode(payload, f"{self._action_type}Goal", fmt="cdr")
        except MessageError as exc:
            _log.error("%s: goal %d rejected, it does not decode: %s", self.name, goal_id, exc)
            self.send(ServedAccept(goal_id, False))
            return
        goal = Ros2ServerGoal(self, goal_id, self.clock(), message)
        with self.lock:
            self.goals[goal_id] = goal
        self.on_goal(goal)

    def cancel_requested(self, goal_id: int) -> None:
        """A ROS 2 client asked to cancel `goal_id` (if it is one of ours)."""
        with self.lock:
            goal = self.goals.get(goal_id)
            if goal is None or goal.status not in (PENDING, ACTIVE):
                return
            goal.status = RECALLING if goal.status == PENDING else PREEMPTING
        if self.on_cancel is not None:
            self.on_cancel(goal)
        else:
            goal.canceled()

    def connection_lost(self) -> None:
        """Every goal is gone (the endpoint aborted them)."""
        with self.lock:
            goals, self.goals = self.goals, {}
            for goal in goals.values():
                goal.lost = True

    def close(self) -> None:
        """Stop serving (the endpoint aborts the goals still running)."""
        self.connector.unserve_action(self.name, self)
        self.connection_lost()


def action_server(
    connector: Connector,
    name: str,
    action_type: str,
    on_goal: Callable[[Any], None],
    on_cancel: Callable[[Any], None] | None = None,
    *,
    clock: Callable[[], float] = time.time,
) -> ActionServer | Ros2ActionServer:
    """The action server for the endpoint `connector` talks to (connect it first): served
    through the endpoint (`action_servers`) on a ROS 2 endpoint, actionlib's topics
    otherwise. `on_goal` and `on_cancel` get a `ServerGoal` or a `Ros2ServerGoal`."""
    if connector.protocol == "ROS2":
        return Ros2ActionServer(connector, name, action_type, on_goal, on_cancel, clock=clock)
    return ActionServer(connector, name, action_type, on_goal, on_cancel, clock=clock)
