"""One client's ROS 2 action goals (the `actions` extension), for its `ClientSession`.

Each goal is a task: send it through the backend, report acceptance, feedback and status
changes, then the result. Goals in flight are bounded per client; a goal that ends
without a result gets an `__error` carrying its `goal_id`. When the client leaves, its
goals are cancelled on the server and forgotten.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Coroutine
from dataclasses import dataclass, field
from typing import Any, Protocol

from simbridge.endpoint.backends.base import Backend, BackendActionGoal
from simbridge.endpoint.options import EndpointOptions
from simbridge.endpoint.session.served_actions import (
    SERVED_COMMANDS,
    ServedCommand,
    SessionServedActions,
)
from simbridge.endpoint.session.stats import SessionStats
from simbridge.errors import SimbridgeError
from simbridge.protocol import (
    MAX_COMMAND_SIZE,
    ActionCancel,
    ActionFeedback,
    ActionGoal,
    ActionResult,
    ActionServerQuery,
    ActionServerReply,
    ActionStatus,
    WarnMessage,
    shorten,
)

__all__ = ["ACTION_COMMANDS", "ActionClient", "ActionCommand", "SessionActions"]

log = logging.getLogger("simbridge.endpoint")

ActionCommand = ActionGoal | ActionCancel | ActionServerQuery | ServedCommand
ACTION_COMMANDS = (ActionGoal, ActionCancel, ActionServerQuery, *SERVED_COMMANDS)
"""The client commands of the `actions` and `action_servers` extensions."""


def _too_big(frame: bytes, name: str) -> bool:
    """Whether a command's JSON exceeds MAX_COMMAND_SIZE (the client would refuse it)."""
    return len(frame) - 8 - len(name) > MAX_COMMAND_SIZE


_MAX_QUERIES = 100
"""`__action_server` queries one client may have waiting for the backend at once."""


@dataclass(slots=True)
class _Goal:
    command: ActionGoal
    task: asyncio.Task[None] | None = None
    backend_goal: BackendActionGoal | None = None
    cancel_requested: bool = False
    helpers: set[asyncio.Task[None]] = field(default_factory=set)


class ActionClient(Protocol):
    """What goal handling needs of the client connection it serves."""

    @property
    def peer(self) -> str:
        """The client's address, for errors and logs."""
        ...

    @property
    def stats(self) -> SessionStats:
        """The connection's counters (goals sent and refused, feedback dropped)."""
        ...

    @property
    def writing_paused(self) -> bool:
        """Whether the client is not reading now (feedback is then dropped)."""
        ...

    def send_control(self, frame: bytes) -> None:
        """Send a frame that must not be dropped."""

    def send_error(
        self, text: str, srv_id: int | None = None, *, goal_id: int | None = None
    ) -> None:
        """Report a failure to the client (with `goal_id`, that goal's)."""


class SessionActions:
    """The action goals of one client connection, sent through `backend`."""

    def __init__(self, client: ActionClient, backend: Backend, options: EndpointOptions) -> None:
        self._client = client
        self._backend = backend
        self._max_goals = options.max_action_goals
        self._timeout = options.service_timeout
        self._goals: dict[int, _Goal] = {}
        self._queries: set[asyncio.Task[None]] = set()
        self.served = SessionServedActions(client, backend, options)
        """The actions the client serves (`action_servers`)."""

    def __len__(self) -> int:
        return len(self._goals)

    def handle(self, command: ActionCommand) -> None:
        """Act on one of the extensions' client commands."""
        if isinstance(command, SERVED_COMMANDS):
            self.served.handle(command)
        elif isinstance(command, ActionGoal):
            self._start(command)
        elif isinstance(command, ActionCancel):
            self._cancel(command.goal_id)
        elif len(self._queries) >= _MAX_QUERIES:
            self._client.send_error(
                f"__action_server for {shorten(command.action)} refused: {_MAX_QUERIES} "
                "queries already waiting for an answer"
            )
            self._client.send_control(ActionServerReply(command.action, False).encode())
        else:
            self._spawn(self._queries, self._query(command))

    def close(self) -> None:
        """The client left: cancel its goals on the server and stop following them; abort
        the goals of the actions it served and stop serving them."""
        self.served.close()
        goals, self._goals = self._goals, {}
        for goal in goals.values():
            if goal.backend_goal is not None:
                goal.backend_goal.abandon()
            for task in (goal.task, *goal.helpers):
                if task is not None:
                    task.cancel()
        for task in list(self._queries):
            task.cancel()
        if goals:
            log.info(
                "client %s disconnected; cancelled its %d action goal(s)",
                self._client.peer,
                len(goals),
            )

    # ---- goals ------------------------------------------------------------------------

    def _describe(self, command: ActionGoal) -> str:
        return (
            f"goal {command.goal_id} for {shorten(command.action)} [{shorten(command.action_type)}]"
        )

    def _start(self, command: ActionGoal) -> None:
        session = self._client
        session.stats.goals_sent += 1
        limit = self._max_goals
        if command.goal_id in self._goals:
            session.stats.goals_refused += 1
            session.send_error(
                f"__action_goal refused: goal_id {command.goal_id} is already in flight; "
                "pick a new id for each goal"
            )
            return
        if len(self._goals) >= limit:
            session.stats.goals_refused += 1
            session.send_error(
                f"{self._describe(command)} refused: {len(self._goals)} goals already in "
                f"flight (limit {limit}); wait for results first",
                goal_id=command.goal_id,
            )
            return
        goal = _Goal(command)
        self._goals[command.goal_id] = goal
        goal.task = asyncio.ensure_future(self._run(goal))

    async def _run(self, goal: _Goal) -> None:
        session, command = self._client, goal.command
        goal_id = command.goal_id
        send = session.send_control
        try:
            try:
                accepted = await self._backend.send_goal(
                    command.action,
                    command.action_type,
                    command.goal,
                    on_feedback=lambda data: self._feedback(goal_id, data),
                    on_status=lambda status: send(ActionStatus(goal_id, status).encode()),
                    timeout=self._timeout,
                )
            except SimbridgeError as exc:
                session.stats.goals_refused += 1
                session.send_error(f"{self._describe(command)} failed: {exc}", goal_id=goal_id)
                return
            if self._goals.get(goal_id) is not goal:  # the client left meanwhile
                accepted.abandon()
                return
            goal.backend_goal = accepted
            if goal.cancel_requested:
                self._spawn(goal.helpers, self._request_cancel(goal, accepted))
            try:
                status, result = await accepted.result()
            except SimbridgeError as exc:
                session.send_error(
                    f"{self._describe(command)} ended without a result: {exc}", goal_id=goal_id
                )
                return
            frame = ActionResult(goal_id, status, result).encode()
            if _too_big(frame, ActionResult.NAME):
                session.send_error(
                    f"{self._describe(command)} ended ({status}) with a result of "
                    f"{len(result):,} bytes, more than a system command carries "
                    f"({MAX_COMMAND_SIZE:,} bytes of JSON, base64 inside)",
                    goal_id=goal_id,
                )
                return
            send(frame)
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # a backend failure must not end the session
            log.exception("client %s: %s failed", session.peer, self._describe(command))
            session.send_error(
                f"{self._describe(command)} failed: {type(exc).__name__}: {shorten(str(exc), 200)}",
                goal_id=goal_id,
            )
        finally:
            if self._goals.get(goal_id) is goal:
                del self._goals[goal_id]
                for task in goal.helpers:
                    task.cancel()

    def _feedback(self, goal_id: int, data: bytes) -> None:
        """Feedback is a sample, not a record: dropped (counted) while the client is not
        reading, so a fast server cannot fill the control backlog that would end the
        connection."""
        session = self._client
        if session.writing_paused:
            session.stats.feedback_dropped += 1
            return
        frame = ActionFeedback(goal_id, data).encode()
        if _too_big(frame, ActionFeedback.NAME):
            session.stats.feedback_dropped += 1
            return
        session.send_control(frame)

    def _cancel(self, goal_id: int) -> None:
        goal = self._goals.get(goal_id)
        if goal is None:
            self._client.send_control(
                WarnMessage(
                    f"__action_cancel: goal {goal_id} is not in flight (it ended already, or "
                    "was never sent)",
                    goal_id=goal_id,
                ).encode()
            )
        elif goal.backend_goal is None:
            goal.cancel_requested = True  # cancelled as soon as the server accepts it
        else:
            self._spawn(goal.helpers, self._request_cancel(goal, goal.backend_goal))

    async def _request_cancel(self, goal: _Goal, accepted: BackendActionGoal) -> None:
        try:
            agreed = await accepted.cancel()
        except SimbridgeError as exc:
            agreed, why = False, str(exc)
        else:
            why = "the server refused"
        if not agreed:
            self._client.send_control(
                WarnMessage(
                    f"cancel of {self._describe(goal.command)} failed: {why}; it goes on",
                    goal_id=goal.command.goal_id,
                ).encode()
            )

    # ---- servers ----------------------------------------------------------------------

    async def _query(self, command: ActionServerQuery) -> None:
        session = self._client
        ready = False
        try:
            ready = await self._backend.action_server_ready(command.action, command.action_type)
        except SimbridgeError as exc:
            session.send_error(
                f"__action_server for {shorten(command.action)} "
                f"[{shorten(command.action_type)}] failed: {exc}"
            )
        session.send_control(ActionServerReply(command.action, ready).encode())

    def _spawn(self, tasks: set[asyncio.Task[None]], coro: Coroutine[Any, Any, None]) -> None:
        task = asyncio.ensure_future(coro)
        tasks.add(task)
        task.add_done_callback(tasks.discard)
