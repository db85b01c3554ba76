"""One client's served ROS 2 actions (the `action_servers` extension), for its session.

Each `__action_serve` becomes a backend action server whose goals are sent to the client as
`__action_request`; the client's answers, feedback and results go back to the server of the
goal. Served actions are bounded per client; when the client leaves (or unserves one), the
goals still running are aborted and the servers leave the graph.
"""

from __future__ import annotations

import logging
from typing import Protocol

from simbridge.endpoint.backends.base import Backend
from simbridge.endpoint.backends.served import BackendActionServer
from simbridge.endpoint.options import EndpointOptions
from simbridge.endpoint.session.stats import SessionStats
from simbridge.errors import EndpointError
from simbridge.protocol import (
    MAX_COMMAND_SIZE,
    ServeAction,
    ServedAccept,
    ServedCancelRequest,
    ServedFeedback,
    ServedGoalRequest,
    ServedResult,
    UnserveAction,
    shorten,
)

__all__ = [
    "MAX_SERVED_ACTIONS",
    "SERVED_COMMANDS",
    "ServedCommand",
    "ServingClient",
    "SessionServedActions",
]

log = logging.getLogger("simbridge.endpoint")

MAX_SERVED_ACTIONS = 64
"""Actions one client may serve at once."""

ServedCommand = ServeAction | UnserveAction | ServedAccept | ServedFeedback | ServedResult
SERVED_COMMANDS = (ServeAction, UnserveAction, ServedAccept, ServedFeedback, ServedResult)


class ServingClient(Protocol):
    """What serving needs of the client connection."""

    @property
    def peer(self) -> str:
        """The client's address, for errors and logs."""
        ...

    @property
    def stats(self) -> SessionStats:
        """The connection's counters (served goals, rejected and aborted)."""
        ...

    def send_control(self, frame: bytes) -> None:
        """Send a frame that must not be dropped."""

    def send_error(self, text: str) -> None:
        """Report a failure to the client."""


class _Sink:
    """Sends one served action's goals and cancel requests to the client."""

    def __init__(self, owner: SessionServedActions, action: str) -> None:
        self._owner = owner
        self._action = action

    def goal(self, goal_id: int, payload: bytes) -> None:
        self._owner.goal_requested(self._action, goal_id, payload)

    def cancel(self, goal_id: int) -> None:
        self._owner.cancel_requested(goal_id)


class SessionServedActions:
    """The actions one client connection serves, hosted by `backend`."""

    def __init__(self, client: ServingClient, backend: Backend, options: EndpointOptions) -> None:
        self._client = client
        self._backend = backend
        self._options = options
        self._servers: dict[str, BackendActionServer] = {}
        self._goals: dict[int, str] = {}
        """Goal id -> its action, from the request to the result (or rejection)."""

    def __len__(self) -> int:
        return len(self._servers)

    def handle(self, command: ServedCommand) -> None:
        """Act on one of the extension's client commands; EndpointError names what is wrong."""
        if isinstance(command, ServeAction):
            self._serve(command)
        elif isinstance(command, UnserveAction):
            self._unserve(command.action)
        else:
            action = self._goals.get(command.goal_id)
            server = self._servers.get(action) if action is not None else None
            if server is None:
                raise EndpointError(
                    f"goal {command.goal_id} is not a goal of an action this client serves "
                    "(it ended, timed out unanswered, or was never requested)"
                )
            try:
                if isinstance(command, ServedAccept):
                    server.accept(command.goal_id, command.accepted)
                    if not command.accepted:
                        del self._goals[command.goal_id]
                        self._client.stats.served_goals_rejected += 1
                elif isinstance(command, ServedFeedback):
                    server.feedback(command.goal_id, command.feedback)
                else:
                    server.finish(command.goal_id, command.status, command.result)
                    del self._goals[command.goal_id]
            except EndpointError:
                if isinstance(command, ServedAccept):  # timed out unanswered: forgotten
                    self._goals.pop(command.goal_id, None)
                raise

    def _serve(self, command: ServeAction) -> None:
        if command.action in self._servers:
            self._unserve(command.action)
        if len(self._servers) >= MAX_SERVED_ACTIONS:
            raise EndpointError(
                f"{shorten(command.action)} not served: this client already serves "
                f"{MAX_SERVED_ACTIONS} actions (the limit); __action_unserve some first"
            )
        server = self._backend.serve_action(
            command.action, command.action_type, _Sink(self, command.action)
        )
        self._servers[command.action] = server
        log.info(
            "client %s serves action %s [%s]",
            self._client.peer,
            command.action,
            command.action_type,
        )

    def _unserve(self, action: str) -> None:
        server = self._servers.pop(action, None)
        if server is None:
            raise EndpointError(f"{shorten(action)} is not served by this client")
        server.close()
        for goal_id in [g for g, a in self._goals.items() if a == action]:
            del self._goals[goal_id]
            self._client.stats.served_goals_aborted += 1

    def goal_requested(self, action: str, goal_id: int, payload: bytes) -> None:
        """A ROS client's goal: to the client (rejected at once when its frame is too big)."""
        frame = ServedGoalRequest(goal_id, action, payload).encode()
        server = self._servers.get(action)
        if server is None:
            return
        stats = self._client.stats
        stats.served_goals += 1
        if len(frame) - 8 - len(ServedGoalRequest.NAME) > MAX_COMMAND_SIZE:
            server.accept(goal_id, False)
            stats.served_goals_rejected += 1
            self._client.send_error(
                f"a goal of {len(payload):,} bytes for {shorten(action)} was rejected: more "
                f"than a system command carries ({MAX_COMMAND_SIZE:,} bytes of JSON)"
            )
            return
        self._goals[goal_id] = action
        self._client.send_control(frame)

    def cancel_requested(self, goal_id: int) -> None:
        """A ROS client asked to cancel a running goal."""
        if goal_id in self._goals:
            self._client.send_control(ServedCancelRequest(goal_id).encode())

    def close(self) -> None:
        """The client left: abort its goals and stop serving."""
        servers, self._servers = self._servers, {}
        goals = len(self._goals)
        self._goals.clear()
        self._client.stats.served_goals_aborted += goals
        for server in servers.values():
            server.close()
        if servers:
            log.info(
                "client %s disconnected; stopped serving %d action(s), %d goal(s) aborted",
                self._client.peer,
                len(servers),
                goals,
            )
