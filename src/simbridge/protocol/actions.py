"""simbridge extension `actions`: a client's ROS 2 action goals, keyed by a goal id it picks.

An endpoint whose backend can reach ROS 2 action servers announces "actions" in its
handshake. Payloads are CDR (ROS 2 layouts), base64 in the JSON of each command, so every
action frame is one system command (the 1 MiB command limit bounds a goal).

Client to endpoint:
- `__action_goal` {"goal_id", "action", "action_type", "goal"}: send a goal.
- `__action_cancel` {"goal_id"}: ask the server to cancel that goal.
- `__action_server` {"action", "action_type"}: is a server there now?

Endpoint to client:
- `__action_server` {"action", "ready"}: the answer.
- `__action_status` {"goal_id", "status"}: accepted, executing or canceling
  (action_msgs/GoalStatus values).
- `__action_feedback` {"goal_id", "feedback"}.
- `__action_result` {"goal_id", "status", "result"}: the end (succeeded, canceled,
  aborted); the goal id is free again.
- `__error` {"text", "goal_id"}: the goal ended without a result (unknown type, no
  server, rejected by the server, too many goals in flight); the text names why.
"""

from __future__ import annotations

import base64
import binascii
from dataclasses import dataclass
from typing import Any, ClassVar

from simbridge.errors import ProtocolError
from simbridge.protocol.commands import (
    Command,
    _get_bool,
    _get_int,
    _get_name,
    register_command,
    shorten,
)

__all__ = [
    "ACTIONS_EXTENSION",
    "STATUS_ABORTED",
    "STATUS_ACCEPTED",
    "STATUS_CANCELED",
    "STATUS_CANCELING",
    "STATUS_EXECUTING",
    "STATUS_SUCCEEDED",
    "ActionCancel",
    "ActionFeedback",
    "ActionGoal",
    "ActionResult",
    "ActionServerQuery",
    "ActionServerReply",
    "ActionStatus",
]

ACTIONS_EXTENSION = "actions"
"""The name an endpoint announces in its handshake's `extensions` when it has these."""

STATUS_ACCEPTED, STATUS_EXECUTING, STATUS_CANCELING = 1, 2, 3
STATUS_SUCCEEDED, STATUS_CANCELED, STATUS_ABORTED = 4, 5, 6
"""action_msgs/GoalStatus values."""

_RUNNING = (STATUS_ACCEPTED, STATUS_EXECUTING, STATUS_CANCELING)
_TERMINAL = (STATUS_SUCCEEDED, STATUS_CANCELED, STATUS_ABORTED)


def _b64(data: bytes) -> str:
    return base64.b64encode(data).decode("ascii")


def _get_bytes(name: str, obj: dict[str, Any], key: str) -> bytes:
    value = obj.get(key, "")
    if not isinstance(value, str):
        raise ProtocolError(f"{name}: field {key!r} must be a base64 string, got {shorten(value)}")
    try:
        return base64.b64decode(value.rstrip("\x00"), validate=True)
    except (binascii.Error, ValueError):
        raise ProtocolError(
            f"{name}: field {key!r} is not valid base64 ({len(value):,} characters)"
        ) from None


def _goal_id(name: str, obj: dict[str, Any]) -> int:
    return _get_int(name, obj, "goal_id", low=0)


def _status(name: str, obj: dict[str, Any], allowed: tuple[int, ...]) -> int:
    status = _get_int(name, obj, "status")
    if status not in allowed:
        raise ProtocolError(
            f"{name}: status {status} is not one of {', '.join(map(str, allowed))} "
            "(action_msgs/GoalStatus)"
        )
    return status


@dataclass(frozen=True, slots=True)
class _ActionTyped(Command):
    """The shape {"action", "action_type"}: an action by name and type (`pkg/Action`)."""

    action: str
    action_type: str

    def to_json(self) -> dict[str, Any]:
        return {"action": self.action, "action_type": self.action_type}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(
            _get_name(cls.NAME, obj, "action"),
            _get_name(cls.NAME, obj, "action_type", kind="type"),
        )


@dataclass(frozen=True, slots=True)
class _GoalOnly(Command):
    """The shape {"goal_id"}: a goal by id alone."""

    goal_id: int

    def to_json(self) -> dict[str, Any]:
        return {"goal_id": self.goal_id}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(_goal_id(cls.NAME, obj))


@dataclass(frozen=True, slots=True)
class _GoalFeedback(Command):
    """The shape {"goal_id", "feedback"}: feedback (CDR) for a goal."""

    goal_id: int
    feedback: bytes

    def to_json(self) -> dict[str, Any]:
        return {"goal_id": self.goal_id, "feedback": _b64(self.feedback)}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(_goal_id(cls.NAME, obj), _get_bytes(cls.NAME, obj, "feedback"))


@dataclass(frozen=True, slots=True)
class _GoalEnd(Command):
    """The shape {"goal_id", "status", "result"}: a goal's terminal status and result (CDR)."""

    goal_id: int
    status: int
    result: bytes

    def to_json(self) -> dict[str, Any]:
        return {"goal_id": self.goal_id, "status": self.status, "result": _b64(self.result)}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(
            _goal_id(cls.NAME, obj),
            _status(cls.NAME, obj, _TERMINAL),
            _get_bytes(cls.NAME, obj, "result"),
        )


@register_command("client")
@dataclass(frozen=True, slots=True)
class ActionGoal(Command):
    """Send `goal` (CDR of the action's Goal) to the ROS 2 action server `action`."""

    NAME: ClassVar[str] = "__action_goal"
    goal_id: int
    action: str
    action_type: str
    goal: bytes

    def to_json(self) -> dict[str, Any]:
        return {
            "goal_id": self.goal_id,
            "action": self.action,
            "action_type": self.action_type,
            "goal": _b64(self.goal),
        }

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(
            _goal_id(cls.NAME, obj),
            _get_name(cls.NAME, obj, "action"),
            _get_name(cls.NAME, obj, "action_type", kind="type"),
            _get_bytes(cls.NAME, obj, "goal"),
        )


@register_command("client")
@dataclass(frozen=True, slots=True)
class ActionCancel(_GoalOnly):
    """Ask the server to cancel the client's goal `goal_id`."""

    NAME: ClassVar[str] = "__action_cancel"


@register_command("client")
@dataclass(frozen=True, slots=True)
class ActionServerQuery(_ActionTyped):
    """Is an action server for `action` (of `action_type`) reachable now?"""

    NAME: ClassVar[str] = "__action_server"


@register_command("endpoint")
@dataclass(frozen=True, slots=True)
class ActionServerReply(Command):
    """The answer to `ActionServerQuery`."""

    NAME: ClassVar[str] = "__action_server"
    action: str
    ready: bool

    def to_json(self) -> dict[str, Any]:
        return {"action": self.action, "ready": self.ready}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(_get_name(cls.NAME, obj, "action"), _get_bool(cls.NAME, obj, "ready", False))


@register_command("endpoint")
@dataclass(frozen=True, slots=True)
class ActionStatus(Command):
    """A running goal's new status: accepted, executing or canceling."""

    NAME: ClassVar[str] = "__action_status"
    goal_id: int
    status: int

    def to_json(self) -> dict[str, Any]:
        return {"goal_id": self.goal_id, "status": self.status}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(_goal_id(cls.NAME, obj), _status(cls.NAME, obj, _RUNNING))


@register_command("endpoint")
@dataclass(frozen=True, slots=True)
class ActionFeedback(_GoalFeedback):
    """Feedback for goal `goal_id` (CDR of the action's Feedback)."""

    NAME: ClassVar[str] = "__action_feedback"


@register_command("endpoint")
@dataclass(frozen=True, slots=True)
class ActionResult(_GoalEnd):
    """The end of goal `goal_id`: its terminal status and result (CDR of the action's Result)."""

    NAME: ClassVar[str] = "__action_result"
