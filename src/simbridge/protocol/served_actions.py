"""simbridge extension `action_servers`: ROS 2 action servers whose implementation is the client.

The mirror of `actions` (a client's goals to ROS 2 servers): the client registers an action,
the endpoint hosts a ROS 2 action server for it and hands each goal a ROS 2 client sends to
the client, which accepts or rejects it, sends feedback and ends it with a result. Goal ids
are the endpoint's, unique on the connection (a space apart from `actions`' ids). Payloads
are CDR (ROS 2 layouts), base64 in the JSON, as in `actions`.

Client to endpoint:
- `__action_serve` {"action", "action_type"}: serve `action` (again after a reconnect).
- `__action_unserve` {"action"}: stop serving it; its running goals are aborted.
- `__action_accept` {"goal_id", "accepted"}: the answer to a goal request.
- `__action_serve_feedback` {"goal_id", "feedback"}.
- `__action_serve_result` {"goal_id", "status", "result"}: the end, status succeeded,
  canceled or aborted (action_msgs/GoalStatus). Canceled without a cancel request is a
  preemption (a newer goal replaced it).

Endpoint to client:
- `__action_request` {"goal_id", "action", "goal"}: a new goal; answer with
  `__action_accept` within the endpoint's service timeout, or it is rejected.
- `__action_cancel_request` {"goal_id"}: a ROS 2 client asked to cancel the goal (the
  endpoint agreed); end it with a result, canceled unless it ended already.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from simbridge.protocol.actions import (
    _ActionTyped,
    _b64,
    _get_bytes,
    _goal_id,
    _GoalEnd,
    _GoalFeedback,
    _GoalOnly,
)
from simbridge.protocol.commands import Command, _get_bool, _get_name, register_command

__all__ = [
    "ACTION_SERVERS_EXTENSION",
    "ServeAction",
    "ServedAccept",
    "ServedCancelRequest",
    "ServedFeedback",
    "ServedGoalRequest",
    "ServedResult",
    "UnserveAction",
]

ACTION_SERVERS_EXTENSION = "action_servers"
"""The name an endpoint announces in its handshake's `extensions` when it has these."""


@register_command("client")
@dataclass(frozen=True, slots=True)
class ServeAction(_ActionTyped):
    """Serve ROS 2 action `action` of type `action_type` (`pkg/Action`) from this client."""

    NAME: ClassVar[str] = "__action_serve"


@register_command("client")
@dataclass(frozen=True, slots=True)
class UnserveAction(Command):
    """Stop serving `action`; its goals still running are aborted."""

    NAME: ClassVar[str] = "__action_unserve"
    action: str

    def to_json(self) -> dict[str, Any]:
        return {"action": self.action}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(_get_name(cls.NAME, obj, "action"))


@register_command("endpoint")
@dataclass(frozen=True, slots=True)
class ServedGoalRequest(Command):
    """A ROS 2 client sent `goal` (CDR of the action's Goal) to the served `action`."""

    NAME: ClassVar[str] = "__action_request"
    goal_id: int
    action: str
    goal: bytes

    def to_json(self) -> dict[str, Any]:
        return {"goal_id": self.goal_id, "action": self.action, "goal": _b64(self.goal)}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(
            _goal_id(cls.NAME, obj),
            _get_name(cls.NAME, obj, "action"),
            _get_bytes(cls.NAME, obj, "goal"),
        )


@register_command("client")
@dataclass(frozen=True, slots=True)
class ServedAccept(Command):
    """The client's answer to goal request `goal_id`."""

    NAME: ClassVar[str] = "__action_accept"
    goal_id: int
    accepted: bool

    def to_json(self) -> dict[str, Any]:
        return {"goal_id": self.goal_id, "accepted": self.accepted}

    @classmethod
    def from_json(cls, obj: dict[str, Any]) -> Command:
        return cls(_goal_id(cls.NAME, obj), _get_bool(cls.NAME, obj, "accepted", False))


@register_command("client")
@dataclass(frozen=True, slots=True)
class ServedFeedback(_GoalFeedback):
    """Feedback for the served goal `goal_id` (CDR of the action's Feedback)."""

    NAME: ClassVar[str] = "__action_serve_feedback"


@register_command("client")
@dataclass(frozen=True, slots=True)
class ServedResult(_GoalEnd):
    """The end of the served goal `goal_id`: succeeded, canceled or aborted, and its result."""

    NAME: ClassVar[str] = "__action_serve_result"


@register_command("endpoint")
@dataclass(frozen=True, slots=True)
class ServedCancelRequest(_GoalOnly):
    """A ROS 2 client asked to cancel the served goal `goal_id`."""

    NAME: ClassVar[str] = "__action_cancel_request"
