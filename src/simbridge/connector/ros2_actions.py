"""ROS 2 actions through a connector, over the endpoint's `actions` extension.

`Ros2ActionClient` has the API of the ROS 1 `ActionClient` (actionlib topics):
`wait_for_server`, `send_goal(goal, on_feedback)` returning a goal with `status`, `text`,
`feedback`, `result`, `done`, `wait` and `cancel`, plus `cancel_all` and `close`, and
`status` holds actionlib's GoalStatus values, so code written for one runs on the other.
`action_client` picks the right one for the endpoint a connector talks to.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import TimeoutError as FutureTimeoutError
from typing import Any

from simbridge.connector.actions import ActionClient
from simbridge.connector.codec import is_raw
from simbridge.connector.connector import Connector
from simbridge.errors import ConnectorError, MessageError
from simbridge.messages.actionlib import (
    ABORTED,
    ACTIVE,
    LOST,
    PENDING,
    PREEMPTED,
    PREEMPTING,
    REJECTED,
    SUCCEEDED,
)
from simbridge.protocol import (
    ACTIONS_EXTENSION,
    MAX_COMMAND_SIZE,
    STATUS_ABORTED,
    STATUS_ACCEPTED,
    STATUS_CANCELED,
    STATUS_CANCELING,
    STATUS_EXECUTING,
    STATUS_SUCCEEDED,
    ActionCancel,
    ActionGoal,
    ActionServerQuery,
)

__all__ = ["ACTIONLIB_STATUS", "Ros2ActionClient", "Ros2ClientGoal", "action_client"]

ACTIONLIB_STATUS = {
    STATUS_ACCEPTED: PENDING,
    STATUS_EXECUTING: ACTIVE,
    STATUS_CANCELING: PREEMPTING,
    STATUS_SUCCEEDED: SUCCEEDED,
    STATUS_CANCELED: PREEMPTED,
    STATUS_ABORTED: ABORTED,
}
"""action_msgs/GoalStatus -> actionlib's GoalStatus (a goal refused or rejected before it
ran is REJECTED; one whose connection was lost is LOST)."""

_MAX_GOAL = (MAX_COMMAND_SIZE - 64 * 1024) // 4 * 3
"""Largest serialized goal sent: its base64 plus names and ids fit in one system command."""
_QUERY_WAIT = 2.0
"""Longest wait for one `__action_server` reply before asking again."""


class Ros2ClientGoal:
    """A goal sent by a `Ros2ActionClient`: its latest status, feedback and result."""

    def __init__(self, client: Ros2ActionClient) -> None:
        self.client = client
        self.id = 0
        """The goal id this connector gave it (the extension's `goal_id`)."""
        self.status: int | None = None
        """actionlib's GoalStatus value (SUCCEEDED is 3), as the ROS 1 client's goals."""
        self.ros2_status: int | None = None
        """The same as action_msgs/GoalStatus (SUCCEEDED is 4); None if never accepted."""
        self.text = ""
        """Why the goal ended without a result (the endpoint's error), else empty."""
        self.result: Any = None
        self.feedback: Any = None
        self.on_feedback: Callable[[Any], None] | None = None
        self._done = threading.Event()

    @property
    def done(self) -> bool:
        """True once the result (or the error that ended the goal) arrived."""
        return self._done.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the goal ended; False on timeout."""
        return self._done.wait(timeout)

    def cancel(self) -> None:
        """Ask the server to cancel this goal (its result then says PREEMPTED)."""
        if not self.done:
            self.client._send(ActionCancel(self.id))

    # ---- GoalSink (called as the connector's callbacks, one at a time) -------------------

    def goal_status(self, status: int) -> None:
        self.ros2_status, self.status = status, ACTIONLIB_STATUS[status]

    def goal_feedback(self, payload: bytes) -> None:
        self.feedback = self.client._decode(payload, "Feedback")
        if self.on_feedback is not None:
            self.on_feedback(self.feedback)

    def goal_result(self, status: int, payload: bytes) -> None:
        self.ros2_status, self.status = status, ACTIONLIB_STATUS[status]
        try:
            self.result = self.client._decode(payload, "Result")
        except MessageError as exc:
            self.text = f"the result could not be decoded: {exc}"
        self._end()

    def goal_error(self, text: str) -> None:
        self.status = REJECTED if self.ros2_status is None else LOST
        self.text = text
        self._end()

    def _end(self) -> None:
        self.client.goals.pop(self.id, None)
        self._done.set()


class Ros2ActionClient:
    """Sends goals to the ROS 2 action `name` through a connector to a ROS 2 endpoint.

    The connector's registry must know the action (`<Action>Goal`, `Result`, `Feedback`;
    load your package with `registry.load_packages`). An endpoint that did not announce
    the `actions` extension (a ROS 1 or Unity endpoint) is refused with ConnectorError.
    """

    def __init__(self, connector: Connector, name: str, action_type: str) -> None:
        self.connector = connector
        self.name = name.rstrip("/") or name
        self.action_type = action_type
        self.goals: dict[int, Ros2ClientGoal] = {}
        for part in ("Goal", "Result", "Feedback"):
            connector.registry.msg_class(f"{action_type}{part}")  # unknown: a clear error now
        if connector.connected:
            self._check_offered()

    def _check_offered(self) -> None:
        if ACTIONS_EXTENSION not in self.connector.extensions:
            raise ConnectorError(
                f"the endpoint at {self.connector.host}:{self.connector.port} does not offer "
                f"ROS 2 actions (it announced {sorted(self.connector.extensions) or 'none'} "
                "as extensions; simbridge's `--backend ros2` endpoint does); for actionlib "
                "over topics use simbridge.connector.ActionClient"
            )

    def _send(self, command: ActionGoal | ActionCancel | ActionServerQuery) -> None:
        self._check_offered()
        self.connector._send_extension(command, ACTIONS_EXTENSION)

    def _decode(self, payload: bytes, part: str) -> Any:
        connector = self.connector
        return connector.registry.decode(payload, f"{self.action_type}{part}", fmt="cdr")

    def wait_for_server(self, timeout: float | None = None) -> bool:
        """True once the endpoint sees an action server for `name`; False after `timeout`."""
        deadline = None if timeout is None else time.monotonic() + timeout

        def left() -> float | None:
            return None if deadline is None else max(0.0, deadline - time.monotonic())

        if not self.connector.wait_connected(left()):
            return False
        router = self.connector._goals
        while True:
            reply = router.expect_reply(self.name)
            try:
                self._send(ActionServerQuery(self.name, self.action_type))
            except ConnectorError:
                reply.cancel()
                raise
            remaining = left()
            wait = _QUERY_WAIT if remaining is None else min(_QUERY_WAIT, remaining)
            try:
                if reply.result(wait):
                    return True
            except FutureTimeoutError:
                reply.cancel()
            remaining = left()
            if remaining is not None and remaining <= 0:
                return False
            time.sleep(0.1 if remaining is None else min(0.1, remaining))

    def send_goal(
        self, goal: Any, on_feedback: Callable[[Any], None] | None = None
    ) -> Ros2ClientGoal:
        """Send `goal` (an `<Action>Goal` message, or its serialized bytes); feedback goes
        to `on_feedback` as the connector's callbacks (one at a time)."""
        connector = self.connector
        if is_raw(goal):
            payload = bytes(goal)
        else:
            payload = connector.registry.encode(goal, f"{self.action_type}Goal", fmt="cdr")
        if len(payload) > _MAX_GOAL:
            raise ConnectorError(
                f"a goal of {len(payload):,} bytes is more than the actions extension carries "
                f"({_MAX_GOAL:,} bytes: base64 in a system command of at most "
                f"{MAX_COMMAND_SIZE:,} bytes)"
            )
        handle = Ros2ClientGoal(self)
        handle.on_feedback = on_feedback
        router = connector._goals
        handle.id = router.add(handle)
        self.goals[handle.id] = handle
        try:
            self._send(ActionGoal(handle.id, self.name, self.action_type, payload))
        except ConnectorError:
            router.forget(handle.id)
            self.goals.pop(handle.id, None)
            raise
        return handle

    def cancel_all(self) -> None:
        """Cancel every goal of this client still in flight."""
        for goal in list(self.goals.values()):
            goal.cancel()

    def close(self) -> None:
        """Stop following this client's goals (they go on until they end or are cancelled)."""
        router = self.connector._goals
        for goal_id in list(self.goals):
            router.forget(goal_id)
        self.goals.clear()


def action_client(
    connector: Connector, name: str, action_type: str
) -> ActionClient | Ros2ActionClient:
    """The action client for the endpoint `connector` talks to (connect it first): ROS 2
    actions (the `actions` extension) on a ROS 2 endpoint, actionlib's topics otherwise."""
    if connector.protocol == "ROS2":
        return Ros2ActionClient(connector, name, action_type)
    return ActionClient(connector, name, action_type)
