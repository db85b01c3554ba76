"""What a backend that hosts action servers for its clients offers (the `action_servers`
extension): a server per registered action, goals handed to a sink on the event loop."""

from __future__ import annotations

import abc
from typing import Protocol

__all__ = ["BackendActionServer", "ServedGoalSink"]


class ServedGoalSink(Protocol):
    """Where a served action's goals go (the client's session); called on the event loop."""

    def goal(self, goal_id: int, payload: bytes) -> None:
        """A ROS client sent a goal (serialized); answer with `BackendActionServer.accept`."""

    def cancel(self, goal_id: int) -> None:
        """A ROS client asked to cancel an accepted goal (the server agreed)."""


class BackendActionServer(abc.ABC):
    """An action server in the graph whose goals a client runs; every method on the event
    loop, each raising EndpointError for a goal id it does not know."""

    @abc.abstractmethod
    def accept(self, goal_id: int, accepted: bool) -> None:
        """The client's answer to goal `goal_id`."""

    @abc.abstractmethod
    def feedback(self, goal_id: int, payload: bytes) -> None:
        """Publish serialized feedback of goal `goal_id`."""

    @abc.abstractmethod
    def finish(self, goal_id: int, status: int, payload: bytes) -> None:
        """End goal `goal_id` with a terminal action_msgs/GoalStatus and a serialized result."""

    @abc.abstractmethod
    def close(self) -> None:
        """Abort the goals still running, refuse new ones and leave the graph."""
