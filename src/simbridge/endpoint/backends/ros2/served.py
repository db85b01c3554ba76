"""ROS 2 action servers whose goals a client runs (the `action_servers` extension).

Each served action is an rclpy ActionServer in a reentrant callback group of its own (its
goal callback waits for the client's answer, which must not hold up the node's other
callbacks). Goals hop to the event loop as CDR with an id of the endpoint's; the client's
answer, feedback and result hop back to the rclpy thread, which owns every goal handle.
A goal the client does not answer within the timeout is rejected; closing a server (the
client left or unserved it) aborts its goals, lets the result requests be answered and
only then destroys it.
"""

from __future__ import annotations

import asyncio
import functools
import itertools
import logging
import threading
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import GoalEvent, ServerGoalHandle
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.task import Future as RclpyFuture

from simbridge.endpoint.backends.loop_calls import call_soon_from_thread
from simbridge.endpoint.backends.ros2.actions import RclpySide
from simbridge.endpoint.backends.ros2.cdr import from_client, to_client
from simbridge.endpoint.backends.ros2.msg_types import Ros2Types
from simbridge.endpoint.backends.served import BackendActionServer, ServedGoalSink
from simbridge.errors import EndpointError
from simbridge.protocol import STATUS_ABORTED, STATUS_CANCELED, STATUS_SUCCEEDED

__all__ = ["MAX_SERVED_GOALS", "Ros2ActionServer", "Ros2ServedActions", "ServingSide"]

_log = logging.getLogger(__name__)

MAX_SERVED_GOALS = 64
"""Goals one served action may have waiting for an answer or running; more are rejected."""
_EARLY_FEEDBACK = 100
"""Feedback kept while rclpy has not handed the accepted goal over yet (oldest dropped)."""
_MAX_POSTED = 1000
"""Feedback messages one server may have on their way to the rclpy thread; more are dropped
(counted in the backend's `served_feedback_dropped`)."""
_ANSWER_BLOCK = 0.25
"""How long the goal callback blocks the rclpy thread for the client's answer (it comes in
milliseconds) before it awaits the rest of the timeout as an rclpy task; a waiting task keeps
rclpy's executor spinning, a CPU the simulation beside it needs (s)."""
_CLOSE_WAIT = 2.0
"""How long closing waits for aborted goals to end on the rclpy thread before destroying (s)."""
_RESULT_GRACE = 1.0
"""How long a closing server stays after its goals ended, so that rclpy sends their results
(each a task of its own, which rclpy's executor may run after newer ones: it runs the
newest first) before it goes (s)."""


@dataclass(slots=True, eq=False)
class _Goal:
    """One goal, on the rclpy thread."""

    goal_id: int
    request: Any
    answer: RclpyFuture = field(default_factory=RclpyFuture)
    decided: threading.Event = field(default_factory=threading.Event)
    """Set (from the event loop) with `accepted` when the client answered."""
    accepted: bool = False
    outcome: tuple[int, Any] | None = None
    """The client's result: (terminal status, rclpy Result)."""
    handle: ServerGoalHandle | None = None
    early: deque[Any] = field(default_factory=lambda: deque(maxlen=_EARLY_FEEDBACK))


class ServingSide(RclpySide, Protocol):
    """What serving needs of the ROS 2 backend beyond `RclpySide`: waking its executor."""

    def wake_rclpy(self) -> None:
        """Wake the rclpy thread (a future one of its tasks awaits was set)."""


class Ros2ServedActions:
    """The backend's served actions by name (one client each) and the goal id counter."""

    def __init__(self, rclpy_side: ServingSide, types: Ros2Types, counters: dict[str, int]) -> None:
        self.rclpy = rclpy_side
        self.types = types
        self.counters = counters
        self.counters.setdefault("served_feedback_dropped", 0)
        self.servers: dict[str, Ros2ActionServer] = {}
        self.lingering: dict[str, Ros2ActionServer] = {}
        """Closed servers still in the graph (sending their last results); serving the
        action again takes one back, so a reconnecting client's action never has two."""
        self.ids = itertools.count(1)
        self.closing: set[asyncio.Task[None]] = set()
        """Servers waiting for their aborted goals to end before they are destroyed."""

    def serve(
        self, action: str, action_type: str, sink: ServedGoalSink, *, timeout: float
    ) -> Ros2ActionServer:
        """A new server for `action`; EndpointError when another client serves it."""
        if action in self.servers:
            raise EndpointError(
                f"action {action!r} is already served by another client of this endpoint"
            )
        cls = self.types.action(action_type)
        server = self.lingering.pop(action, None)
        if server is not None and server.cls is cls:
            server.reopen(sink, timeout)
        else:
            if server is not None:  # another type: the old one goes now
                server.destroy_soon(0.0)
            server = Ros2ActionServer(self, action, cls, sink, timeout=timeout)
        self.servers[action] = server
        _log.info("serving action %s [%s] for a client", action, action_type)
        return server

    async def close(self) -> None:
        """Close every server and wait (bounded) until each is destroyed."""
        for server in list(self.servers.values()):
            server.close()
        if self.closing:
            await asyncio.wait(self.closing, timeout=_CLOSE_WAIT * 2)


class Ros2ActionServer(BackendActionServer):
    """One served action. `_known` (goal id -> "asked" or "running") is the event loop's view;
    `_r_goals` the rclpy thread's."""

    def __init__(
        self,
        served: Ros2ServedActions,
        action: str,
        cls: Any,
        sink: ServedGoalSink,
        *,
        timeout: float,
    ) -> None:
        self._served = served
        self._rclpy = served.rclpy
        self._loop = self._rclpy.running_loop()
        self._action = action
        self._cls = cls
        self.cls = cls
        """The action's rclpy class."""
        self._sink = sink
        self._timeout = timeout
        self._known: dict[int, str] = {}
        self._ended: dict[int, asyncio.Future[None]] = {}
        """Accepted goals until rclpy has their result (set from the rclpy thread)."""
        self._r_goals: dict[int, _Goal] = {}
        self._asked: dict[int, _Goal] = {}
        """Goals waiting for the client's answer, for the event loop to answer them."""
        self._r_accepting: dict[int, _Goal] = {}
        """Accepted goals by id() of their request, until rclpy hands over their handle."""
        self._posted = 0
        self._closed = False
        try:
            self._server = ActionServer(
                self._rclpy.node,
                cls,
                action,
                execute_callback=self._r_execute_unknown,
                goal_callback=self._r_on_goal,
                handle_accepted_callback=self._r_accepted,
                cancel_callback=self._r_on_cancel,
                callback_group=ReentrantCallbackGroup(),
            )
        except Exception as exc:
            raise EndpointError(f"cannot serve action {action!r}: {exc}") from exc

    # ---- event loop -------------------------------------------------------------------

    def _check(self, goal_id: int, state: str, what: str) -> None:
        found = self._known.get(goal_id)
        if found != state:
            now = (
                "is running"
                if found == "running"
                else ("waits for an answer" if found == "asked" else "is not in flight")
            )
            raise EndpointError(
                f"{what} for goal {goal_id} of {self._action!r}: the goal {now} (it ended, "
                f"timed out unanswered after {self._timeout:g} s, or was never sent)"
            )

    def accept(self, goal_id: int, accepted: bool) -> None:
        self._check(goal_id, "asked", "__action_accept")
        self._answer(goal_id, accepted)

    def _answer(self, goal_id: int, accepted: bool) -> None:
        asked = self._asked.pop(goal_id, None)
        if asked is not None:
            asked.accepted = accepted
            asked.decided.set()
        if accepted:
            self._known[goal_id] = "running"
            self._ended[goal_id] = self._loop.create_future()
        else:
            del self._known[goal_id]
        self._rclpy.on_rclpy_thread(lambda: self._r_answer(goal_id, accepted))

    def _timed_out(self, goal_id: int) -> None:
        if self._known.get(goal_id) == "asked":
            _log.warning(
                "goal %d of %s: the client did not answer within %g s; rejected",
                goal_id,
                self._action,
                self._timeout,
            )
            self._answer(goal_id, False)

    def feedback(self, goal_id: int, payload: bytes) -> None:
        self._check(goal_id, "running", "feedback")
        if self._posted >= _MAX_POSTED:
            self._served.counters["served_feedback_dropped"] += 1
            return
        self._posted += 1
        self._rclpy.on_rclpy_thread(lambda: self._r_feedback(goal_id, payload))

    def finish(self, goal_id: int, status: int, payload: bytes) -> None:
        self._check(goal_id, "running", "the result")
        if status not in (STATUS_SUCCEEDED, STATUS_CANCELED, STATUS_ABORTED):
            raise EndpointError(f"status {status} does not end a goal (4, 5 or 6)")
        try:
            result = from_client(payload, self._cls.Result)
        except Exception as exc:
            raise EndpointError(
                f"the result of goal {goal_id} of {self._action!r} is not a CDR "
                f"{self._cls.__name__} result: {exc}"
            ) from exc
        del self._known[goal_id]
        self._rclpy.on_rclpy_thread(lambda: self._r_finish(goal_id, status, result))

    def reopen(self, sink: ServedGoalSink, timeout: float) -> None:
        """Serve again, for a new client, before this closed server left the graph."""
        self._sink, self._timeout, self._closed = sink, timeout, False

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self._served.servers.get(self._action) is self:
            del self._served.servers[self._action]
        self._served.lingering[self._action] = self
        running: list[int] = []
        for goal_id, state in list(self._known.items()):
            if state == "asked":
                self._answer(goal_id, False)
            else:
                running.append(goal_id)
        self._known.clear()
        empty = self._cls.Result()
        for goal_id in running:
            self._rclpy.on_rclpy_thread(
                functools.partial(self._r_finish, goal_id, STATUS_ABORTED, empty)
            )
        if running:
            _log.info("aborted %d goal(s) of %s: its client left", len(running), self._action)
        self.destroy_soon(_RESULT_GRACE, list(self._ended.values()))

    def destroy_soon(self, grace: float, ended: list[asyncio.Future[None]] | None = None) -> None:
        """Leave the graph once `ended` goals ended (bounded) and `grace` s passed, unless
        served again meanwhile."""
        task = self._loop.create_task(self._destroy_when_ended(grace, ended or []))
        self._served.closing.add(task)
        task.add_done_callback(self._served.closing.discard)

    async def _destroy_when_ended(self, grace: float, ended: list[asyncio.Future[None]]) -> None:
        if ended:
            _done, left = await asyncio.wait(ended, timeout=_CLOSE_WAIT)
            if left:
                _log.warning("%d goal(s) of %s did not end in time", len(left), self._action)
        await asyncio.sleep(grace)
        if not self._closed:  # served again
            return
        if self._served.lingering.get(self._action) is self:
            del self._served.lingering[self._action]
        await self._rclpy_call(self._server.destroy)
        _log.info("stopped serving action %s", self._action)

    async def _rclpy_call(self, fn: Callable[[], Any]) -> Any:
        future: asyncio.Future[Any] = self._loop.create_future()

        def settle(value: Any, error: BaseException | None) -> None:
            if not future.done():
                if error is None:
                    future.set_result(value)
                else:
                    future.set_exception(error)

        def run() -> None:
            try:
                value = fn()
            except Exception as exc:
                call_soon_from_thread(self._loop, settle, None, exc)
            else:
                call_soon_from_thread(self._loop, settle, value, None)

        self._rclpy.on_rclpy_thread(run)
        try:
            return await asyncio.wait_for(future, _CLOSE_WAIT)
        except Exception as exc:  # the executor is gone: the node goes with everything
            _log.debug("closing served action %s: %s", self._action, exc)
            return []

    def _ask(self, goal: _Goal, payload: bytes) -> None:
        """A goal from the rclpy thread: to the client, with the answer's deadline."""
        goal_id = goal.goal_id
        if self._closed:
            goal.decided.set()
            self._rclpy.on_rclpy_thread(lambda: self._r_answer(goal_id, False))
            return
        self._asked[goal_id] = goal
        self._known[goal_id] = "asked"
        self._loop.call_later(self._timeout, self._timed_out, goal_id)
        self._sink.goal(goal_id, payload)

    def _cancel_asked(self, goal_id: int) -> None:
        if self._known.get(goal_id) == "running":
            self._sink.cancel(goal_id)

    def _executed(self, goal_id: int) -> None:
        ended = self._ended.pop(goal_id, None)
        if ended is not None and not ended.done():
            ended.set_result(None)

    # ---- rclpy thread -----------------------------------------------------------------

    def _post(self, fn: Callable[..., None], *args: Any) -> None:
        call_soon_from_thread(self._loop, fn, *args)

    async def _r_on_goal(self, request: Any) -> GoalResponse:
        """rclpy's goal callback: ask the client, wait for its answer (milliseconds)."""
        if len(self._r_goals) >= MAX_SERVED_GOALS:
            _log.warning(
                "goal for %s rejected: %d goals in flight (the limit)",
                self._action,
                MAX_SERVED_GOALS,
            )
            return GoalResponse.REJECT
        goal = _Goal(next(self._served.ids), request)
        try:
            payload = to_client(request)
        except Exception as exc:
            _log.error("goal for %s cannot be serialized: %s", self._action, exc)
            return GoalResponse.REJECT
        self._r_goals[goal.goal_id] = goal
        self._post(self._ask, goal, payload)
        if goal.decided.wait(_ANSWER_BLOCK):
            accepted = goal.accepted
        else:
            accepted = await goal.answer
        if not accepted:
            self._r_goals.pop(goal.goal_id, None)
            return GoalResponse.REJECT
        self._r_accepting[id(request)] = goal
        return GoalResponse.ACCEPT

    def _r_answer(self, goal_id: int, accepted: bool) -> None:
        goal = self._r_goals.get(goal_id)
        if goal is not None and not goal.answer.done():
            goal.answer.set_result(accepted)
            self._rclpy.wake_rclpy()

    def _r_accepted(self, handle: ServerGoalHandle) -> None:
        """The goal runs (EXECUTING) until the client's result; no execute callback waits
        for it meanwhile (a waiting rclpy task keeps the executor spinning)."""
        goal = self._r_accepting.pop(id(handle.request), None)
        if goal is None:  # not one of ours: cannot happen, but never leave it hanging
            handle.execute()
            return
        goal.handle = handle
        if not handle.is_cancel_requested:
            _r_move(handle, GoalEvent.EXECUTE)
        while goal.early:
            handle.publish_feedback(goal.early.popleft())
        if goal.outcome is not None:
            self._r_end(goal)

    def _r_execute_unknown(self, handle: ServerGoalHandle) -> Any:
        handle.abort()
        return self._cls.Result()

    def _r_end(self, goal: _Goal) -> None:
        """Hand the result to rclpy (an execute callback that returns it at once)."""
        assert goal.handle is not None
        self._server.notify_execute(goal.handle, functools.partial(self._r_result, goal))

    def _r_result(self, goal: _Goal, handle: ServerGoalHandle) -> Any:
        assert goal.outcome is not None
        status, result = goal.outcome
        try:
            if status == STATUS_SUCCEEDED:
                handle.succeed()
            elif status == STATUS_ABORTED:
                handle.abort()
            else:
                if not handle.is_cancel_requested:  # preempted: canceled without a request
                    _r_move(handle, GoalEvent.CANCEL_GOAL)
                handle.canceled()
            return result
        finally:
            self._r_goals.pop(goal.goal_id, None)
            self._post(self._executed, goal.goal_id)

    def _r_feedback(self, goal_id: int, payload: bytes) -> None:
        self._post(self._feedback_sent)
        goal = self._r_goals.get(goal_id)
        if goal is None or goal.outcome is not None:
            return
        try:
            message = from_client(payload, self._cls.Feedback)
        except Exception as exc:
            _log.warning("feedback of goal %d of %s dropped: %s", goal_id, self._action, exc)
            return
        if goal.handle is None:
            goal.early.append(message)
        else:
            goal.handle.publish_feedback(message)

    def _feedback_sent(self) -> None:
        self._posted -= 1

    def _r_finish(self, goal_id: int, status: int, result: Any) -> None:
        goal = self._r_goals.get(goal_id)
        if goal is None or goal.outcome is not None:
            return
        goal.outcome = (status, result)
        if goal.handle is not None:
            self._r_end(goal)

    def _r_on_cancel(self, handle: ServerGoalHandle) -> CancelResponse:
        for goal in self._r_goals.values():
            if goal.handle is handle and goal.outcome is None:
                self._post(self._cancel_asked, goal.goal_id)
                return CancelResponse.ACCEPT
        return CancelResponse.REJECT


def _r_move(handle: ServerGoalHandle, event: Any) -> None:
    """Move a goal to EXECUTING (no execute callback runs until its result is known) or to
    CANCELING (a preemption: rclcpp's canceled() does that itself, rclpy's does not).
    rclpy has no public call for either; this is the one it makes itself."""
    handle._update_state(event)
