"""ROS 2 action goals for the sim (the `actions` extension), through rclpy's ActionClient.

rclpy's ActionClient keeps its pending requests in plain dicts that its executor thread
reads, so every call on it (create, send, cancel, get the result) runs on the rclpy thread
(`executor.create_task`); answers hop back to the event loop. Goals arrive and leave as
CDR: decoded into the action's Goal class with rclpy.serialization, feedback and results
encoded back (`cdr`: an empty part in each side's spelling). One ActionClient per
action and type serves every client of the endpoint.
"""

from __future__ import annotations

import asyncio
import logging
import time
import uuid
from collections import deque
from collections.abc import Callable
from typing import Any, Protocol, TypeVar

from rclpy.action import ActionClient
from rclpy.action.client import ClientGoalHandle

from simbridge.endpoint.backends.base import BackendActionGoal, MessageCallback
from simbridge.endpoint.backends.loop_calls import call_soon_from_thread
from simbridge.endpoint.backends.ros2.cdr import from_client, to_client
from simbridge.endpoint.backends.ros2.msg_types import Ros2Types
from simbridge.errors import EndpointError
from simbridge.protocol import (
    STATUS_ABORTED,
    STATUS_ACCEPTED,
    STATUS_CANCELED,
    STATUS_CANCELING,
    STATUS_EXECUTING,
    STATUS_SUCCEEDED,
)

__all__ = ["MAX_ACTION_CLIENTS", "RclpySide", "Ros2Actions"]

_log = logging.getLogger(__name__)
_T = TypeVar("_T")

MAX_ACTION_CLIENTS = 256
"""Distinct (action, type) pairs the endpoint keeps an ActionClient for; more are refused."""

_RUNNING = (STATUS_EXECUTING, STATUS_CANCELING)
_ENDED = (STATUS_SUCCEEDED, STATUS_CANCELED, STATUS_ABORTED)
_PROBE_EVERY = 0.25
"""How long a probe of a newly found server waits for its answer before another is sent.
We see the server when our side matched; its response writers match our readers on the
server's own schedule (seconds later on a busy machine), and rmw_fastrtps drops a
response whose reader is not matched within 100 ms, so the first goal waits until the
server has answered a probe."""
_SERVER_CHECK = 1.0
"""How often a goal waiting for its result checks that its server is still there (s)."""
_EARLY_FEEDBACK = 100
"""Feedback messages kept while a goal's acceptance is on its way (the oldest dropped)."""
_CANCEL_RETRY = 0.5
"""How long an abandoned goal waits for the server's answer to its cancel before asking
again: a request written before the server's reader matched ours is lost, as is one
written just before our node goes."""
_CANCEL_TRIES = 10
_CLOSE_WAIT = 2.0
"""How long stopping waits for the servers of running goals to answer their cancels (s)."""


class _StatusActionClient(ActionClient):  # type: ignore[misc]  # rclpy has no type hints
    """An ActionClient that reports each goal's status (rclpy only stores it); runs on the
    rclpy thread."""

    def __init__(self, *args: Any, on_status: Callable[[bytes, int], None], **kw: Any) -> None:
        super().__init__(*args, **kw)
        self._on_status = on_status

    async def execute(self, taken_data: Any) -> None:
        status = taken_data.get("status") if isinstance(taken_data, dict) else None
        await super().execute(taken_data)
        if status is not None:
            for entry in status.status_list:
                self._on_status(bytes(entry.goal_info.goal_id.uuid), int(entry.status))


class RclpySide(Protocol):
    """What action handling needs of the ROS 2 backend: its node, the event loop it
    started on, and a way onto the rclpy thread."""

    @property
    def node(self) -> Any:
        """The rclpy node (EndpointError before the backend started)."""
        ...

    def running_loop(self) -> asyncio.AbstractEventLoop:
        """The endpoint's event loop (EndpointError before the backend started)."""
        ...

    def on_rclpy_thread(self, fn: Callable[[], Any]) -> None:
        """Run `fn` on the rclpy thread, as a task of its executor."""


def _random_goal_id(cls: Any) -> Any:
    """A new goal id (the UUID message `cls`'s goal requests carry), made as rclpy makes
    the id of a goal it sends."""
    uuid_class = type(cls.Impl.SendGoalService.Request().goal_id)
    return uuid_class(uuid=list(uuid.uuid4().bytes))


class Ros2Actions:
    """The endpoint node's action clients and the goals sent through them; `types`
    gives each action type's rclpy class."""

    def __init__(self, rclpy_side: RclpySide, types: Ros2Types) -> None:
        self._rclpy = rclpy_side
        self._types = types
        self._clients: dict[tuple[str, str], tuple[Any, Any]] = {}
        """(action, type) -> (ActionClient, action class); touched on the event loop only."""
        self.goals: dict[bytes, _Ros2Goal] = {}
        """Goals by UUID, for status reports; touched on the rclpy thread only."""
        self._answered: set[int] = set()
        """ActionClients (by id) whose server answered a probe since it was found."""
        self.cancelling: set[asyncio.Task[None]] = set()
        """Abandoned goals still asking their server to cancel (event loop)."""

    def on_rclpy(self, fn: Callable[[], _T]) -> asyncio.Future[_T]:
        """Run `fn` on the rclpy thread; its value (or exception) in an event loop future."""
        loop = self._rclpy.running_loop()
        future: asyncio.Future[_T] = loop.create_future()

        def settle(value: Any, error: BaseException | None) -> None:
            if future.done():
                return
            if error is not None:
                future.set_exception(error)
            else:
                future.set_result(value)

        def run() -> None:
            try:
                value = fn()
            except Exception as exc:
                call_soon_from_thread(loop, settle, None, exc)
            else:
                call_soon_from_thread(loop, settle, value, None)

        self._rclpy.on_rclpy_thread(run)
        return future

    async def client(self, action: str, action_type: str) -> tuple[Any, Any]:
        """The ActionClient for `action` and its action class (created on first use)."""
        key = (action, action_type)
        found = self._clients.get(key)
        if found is not None:
            return found
        cls = self._types.action(action_type)
        if len(self._clients) >= MAX_ACTION_CLIENTS:
            raise EndpointError(
                f"no client for action {action!r}: the endpoint already has "
                f"{MAX_ACTION_CLIENTS} action clients (the limit)"
            )
        node = self._rclpy.node
        try:
            client = await self.on_rclpy(
                lambda: _StatusActionClient(node, cls, action, on_status=self._status)
            )
        except Exception as exc:
            raise EndpointError(f"cannot create a client for action {action!r}: {exc}") from exc
        found = self._clients.setdefault(key, (client, cls))
        if found[0] is not client:
            self.on_rclpy(client.destroy)
        else:
            _log.info("action client for %s [%s]", action, action_type)
        return found

    async def server_ready(self, action: str, action_type: str) -> bool:
        """Whether an action server for `action` is discovered now."""
        client, _cls = await self.client(action, action_type)
        return self._ready(client)

    def _ready(self, client: Any) -> bool:
        """`server_is_ready`; a server that is gone must answer a probe again."""
        if not client.server_is_ready():
            self._answered.discard(id(client))
            return False
        return True

    async def _reached(self, client: Any, cls: Any, action: str, deadline: float) -> bool:
        """Whether the server answers a result request for a goal it does not know (every
        server answers STATUS_UNKNOWN at once) before `deadline`, probing again every
        `_PROBE_EVERY` s. Its answer means its side has matched our goal, cancel and result
        response readers (announced in that order), so its answer to a goal will not be
        dropped."""
        if id(client) in self._answered:
            return True
        loop = self._rclpy.running_loop()
        answered: asyncio.Future[None] = loop.create_future()

        def answer() -> None:
            if not answered.done():
                answered.set_result(None)

        def probe() -> None:  # rclpy thread
            accepted = cls.Impl.SendGoalService.Response(accepted=True)
            unknown = ClientGoalHandle(client, _random_goal_id(cls), accepted)
            unknown.get_result_async().add_done_callback(
                lambda _f: call_soon_from_thread(loop, answer)
            )

        start, probes = time.monotonic(), 0
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            self._rclpy.on_rclpy_thread(probe)
            probes += 1
            try:
                await asyncio.wait_for(asyncio.shield(answered), min(_PROBE_EVERY, left))
            except TimeoutError:
                continue
            self._answered.add(id(client))
            _log.info(
                "action server of %s answered after %.2f s (%d probe(s))",
                action,
                time.monotonic() - start,
                probes,
            )
            return True

    async def send_goal(
        self,
        action: str,
        action_type: str,
        goal: bytes,
        *,
        on_feedback: MessageCallback,
        on_status: Callable[[int], None],
        timeout: float,
        discovery_wait: float,
    ) -> BackendActionGoal:
        """See `Backend.send_goal`."""
        client, cls = await self.client(action, action_type)
        try:
            decoded = from_client(goal, cls.Goal)
        except Exception as exc:
            raise EndpointError(f"the goal is not a CDR {action_type} goal: {exc}") from exc
        wait = min(timeout, discovery_wait)
        deadline = time.monotonic() + wait
        while not self._ready(client):
            if time.monotonic() >= deadline:
                raise EndpointError(
                    f"no ROS 2 action server for {action!r} [{action_type}] "
                    f"(none found within {wait:g} s)"
                )
            await asyncio.sleep(0.01)
        if not await self._reached(client, cls, action, time.monotonic() + timeout):
            raise EndpointError(
                f"the action server of {action!r} did not answer within {timeout:g} s "
                f"(a result request for an unknown goal, sent before the first goal)"
            )
        sent = _Ros2Goal(
            self,
            client,
            action,
            loop=self._rclpy.running_loop(),
            on_feedback=on_feedback,
            on_status=on_status,
            lost_after=discovery_wait,
        )
        accepted = sent.start(decoded)
        try:
            ok = await asyncio.wait_for(asyncio.shield(accepted), timeout)
        except TimeoutError:
            sent.abandon()
            raise EndpointError(
                f"the action server of {action!r} did not answer the goal within {timeout:g} s"
            ) from None
        except asyncio.CancelledError:
            sent.abandon()
            raise
        if not ok:
            raise EndpointError(f"the action server of {action!r} rejected the goal")
        return sent

    def _status(self, uuid: bytes, status: int) -> None:
        """From the status topic (rclpy thread)."""
        goal = self.goals.get(uuid)
        if goal is not None:
            goal.status_seen(status)

    async def close(self) -> None:
        """Cancel every goal still running (the endpoint is stopping), wait up to
        `_CLOSE_WAIT` for their servers to answer, and destroy every action client,
        before the node goes."""
        try:
            running = await asyncio.wait_for(self.on_rclpy(lambda: list(self.goals.values())), 2.0)
        except Exception as exc:  # the executor may be gone already
            _log.debug("cancelling goals at close: %s", exc)
            running = []
        for goal in running:
            goal.abandon()
        if self.cancelling:
            _done, unanswered = await asyncio.wait(self.cancelling, timeout=_CLOSE_WAIT)
            for task in unanswered:
                task.cancel()
            if unanswered:
                _log.warning(
                    "%d action server(s) did not answer a cancel within %g s; "
                    "their goals may still run",
                    len(unanswered),
                    _CLOSE_WAIT,
                )
        clients = [client for client, _cls in self._clients.values()]
        self._clients.clear()
        self._answered.clear()
        for client in clients:
            try:
                await asyncio.wait_for(self.on_rclpy(client.destroy), 2.0)
            except Exception as exc:  # the executor may be gone already
                _log.debug("destroying an action client: %s", exc)


class _Ros2Goal(BackendActionGoal):
    """One goal sent through an ActionClient. Fields with a leading `_r` belong to the
    rclpy thread; the rest to the event loop."""

    def __init__(
        self,
        actions: Ros2Actions,
        client: Any,
        action: str,
        *,
        loop: asyncio.AbstractEventLoop,
        on_feedback: MessageCallback,
        on_status: Callable[[int], None],
        lost_after: float,
    ) -> None:
        self._actions = actions
        self._action = action
        self._lost_after = lost_after
        self._client = client
        self._loop = loop
        self._on_feedback = on_feedback
        self._on_status = on_status
        self._accepted: asyncio.Future[bool] = self._loop.create_future()
        self._result: asyncio.Future[tuple[int, bytes]] = self._loop.create_future()
        self._gone = False
        self._cancel_answered: asyncio.Future[None] = self._loop.create_future()
        self._r_handle: Any = None
        self._r_uuid = b""
        self._r_abandoned = False
        self._r_answered = False
        self._r_reported = STATUS_ACCEPTED
        self._r_latest = 0
        self.ended = False
        """Set (on the rclpy thread) once the status topic reports the goal over."""
        self._r_early: deque[Any] = deque(maxlen=_EARLY_FEEDBACK)
        """Feedback that came before the server's acceptance was handled (kept in order)."""

    # ---- event loop -------------------------------------------------------------------

    def start(self, goal: Any) -> asyncio.Future[bool]:
        """Send the goal; the future says whether the server accepted it."""
        self._actions.on_rclpy(lambda: self._r_send(goal)).add_done_callback(self._sent)
        return self._accepted

    def _sent(self, done: asyncio.Future[None]) -> None:
        if not done.cancelled() and done.exception() is not None and not self._accepted.done():
            self._accepted.set_exception(EndpointError(f"cannot send the goal: {done.exception()}"))

    async def result(self) -> tuple[int, bytes]:
        """The result; EndpointError when the server left the graph (not seen for
        `discovery_wait`) without sending it, so a dead server never leaves a goal hanging."""
        missing_since: float | None = None
        ended_checks = 0
        while True:
            try:
                return await asyncio.wait_for(asyncio.shield(self._result), _SERVER_CHECK)
            except TimeoutError:
                pass
            if self.ended:
                # The status topic says the goal is over but no result came: the answer to
                # the result request was lost (a DDS service response can be, while its reader
                # is still being matched). Asking again is harmless.
                ended_checks += 1
                if ended_checks >= 2:
                    ended_checks = 0
                    self._actions.on_rclpy(self._r_ask_result)
            now = time.monotonic()
            if self._client.server_is_ready():
                missing_since = None
            elif missing_since is None:
                missing_since = now
            elif now - missing_since >= self._lost_after:
                self.abandon()
                raise EndpointError(
                    f"the action server of {self._action!r} left the graph "
                    f"(not seen for {self._lost_after:g} s) before sending the result"
                )

    async def cancel(self) -> bool:
        answer: asyncio.Future[bool] = self._loop.create_future()

        def outcome(done: Any) -> None:  # rclpy thread
            error = done.exception()
            if error is not None:
                self._post(self._settle, answer, None, EndpointError(f"cancel failed: {error}"))
                return
            response = done.result()
            agreed = response.return_code == 0 and len(response.goals_canceling) > 0
            self._post(self._settle, answer, agreed, None)

        def ask() -> None:  # rclpy thread
            if self._r_handle is None:
                raise EndpointError("the goal is not accepted yet")
            self._r_handle.cancel_goal_async().add_done_callback(outcome)

        await self._actions.on_rclpy(ask)
        return await answer

    def abandon(self) -> None:
        if self._gone:
            return
        self._gone = True
        task = self._loop.create_task(self._cancel_until_answered())
        self._actions.cancelling.add(task)
        task.add_done_callback(self._actions.cancelling.discard)

    async def _cancel_until_answered(self) -> None:
        """Ask the server to cancel until it answers or reports the goal canceling or
        over (`_CANCEL_TRIES` at most); a refused goal needs no cancel. Before the server
        accepts, there is nothing to ask: the acceptance sends the first request."""
        asked = False
        for _ in range(_CANCEL_TRIES):
            try:
                asked = await self._actions.on_rclpy(self._r_abandon) or asked
            except Exception as exc:  # the backend is closed: the node and its goals are gone
                _log.debug("cancelling an abandoned goal: %s", exc)
                return
            try:
                await asyncio.wait_for(asyncio.shield(self._cancel_answered), _CANCEL_RETRY)
                return
            except TimeoutError:
                pass
            if self.ended or self._r_latest == STATUS_CANCELING or self._refused():
                return
        if asked:
            _log.warning("the action server of %r did not answer a cancel", self._action)

    def _refused(self) -> bool:
        accepted = self._accepted
        if not accepted.done():
            return False
        return accepted.cancelled() or accepted.exception() is not None or not accepted.result()

    def _deliver(self, fn: Callable[..., None], *args: Any) -> None:
        if not self._gone:
            fn(*args)

    def _settle(self, future: asyncio.Future[Any], value: Any, error: BaseException | None) -> None:
        if future.done():
            return
        if error is not None:
            future.set_exception(error)
        else:
            future.set_result(value)

    def _accept(self, ok: bool) -> None:
        """Acceptance first reports STATUS_ACCEPTED, before any feedback posted after it."""
        if ok and not self._gone:
            self._on_status(STATUS_ACCEPTED)
        self._settle(self._accepted, ok, None)

    # ---- rclpy thread -----------------------------------------------------------------

    def _post(self, fn: Callable[..., None], *args: Any) -> None:
        call_soon_from_thread(self._loop, fn, *args)

    def _r_send(self, goal: Any) -> None:
        future = self._client.send_goal_async(goal, feedback_callback=self._r_feedback)
        future.add_done_callback(self._r_response)

    def _r_response(self, future: Any) -> None:
        error = future.exception()
        if error is not None:
            self._post(self._settle, self._accepted, None, EndpointError(str(error)))
            return
        handle = future.result()
        if not handle.accepted:
            self._post(self._accept, False)
            return
        self._r_handle = handle
        self._r_uuid = bytes(handle.goal_id.uuid)
        self._actions.goals[self._r_uuid] = self
        self._post(self._accept, True)
        self._r_answered = True
        for message in self._r_early:
            self._r_feedback(message)
        self._r_early.clear()
        if self._r_latest in _RUNNING:
            self.status_seen(self._r_latest)
        self._r_ask_result()
        if self._r_abandoned:
            self._r_abandon()

    def _r_feedback(self, message: Any) -> None:
        if not self._r_answered:
            self._r_early.append(message)
            return
        if self._r_abandoned:
            return
        data = to_client(message.feedback)
        self._post(self._deliver, self._on_feedback, data)

    def status_seen(self, status: int) -> None:
        """A status for this goal from the status topic (rclpy thread)."""
        self._r_latest = status
        if status in _ENDED:
            self.ended = True
        if self._r_answered and status in _RUNNING and status != self._r_reported:
            self._r_reported = status
            self._post(self._deliver, self._on_status, status)

    def _r_ask_result(self) -> None:
        if self._r_handle is not None:
            self._r_handle.get_result_async().add_done_callback(self._r_result)

    def _r_result(self, future: Any) -> None:
        self._actions.goals.pop(self._r_uuid, None)
        error = future.exception()
        if error is not None:
            self._post(self._settle, self._result, None, EndpointError(f"no result: {error}"))
            return
        response = future.result()
        data = to_client(response.result)
        self._post(self._settle, self._result, (int(response.status), data), None)

    def _r_abandon(self) -> bool:
        """Ask for a cancel (once accepted); whether a request went out."""
        self._r_abandoned = True
        if self._r_handle is None:
            return False
        self._r_handle.cancel_goal_async().add_done_callback(self._r_cancel_answer)
        return True

    def _r_cancel_answer(self, done: Any) -> None:
        if done.exception() is None:
            self._post(self._settle, self._cancel_answered, None, None)
