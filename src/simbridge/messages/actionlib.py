"""actionlib's protocol (ROS 1 actions are five topics): goal, cancel, status, feedback and
result under the action's name, with GoalID/GoalStatus semantics as actionlib implements
them. Transport-neutral: the connector and the local-bus `Node` plug in a transport."""

from __future__ import annotations

import itertools
import logging
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

from simbridge.errors import MessageError
from simbridge.messages.registry import MessageRegistry

__all__ = [
    "ACTIVE",
    "TERMINAL",
    "ActionClientCore",
    "ActionServerCore",
    "ActionTransport",
    "ClientGoal",
    "ServerGoal",
]

_log = logging.getLogger("simbridge.actionlib")

PENDING, ACTIVE, PREEMPTED, SUCCEEDED, ABORTED, REJECTED = 0, 1, 2, 3, 4, 5
PREEMPTING, RECALLING, RECALLED, LOST = 6, 7, 8, 9
TERMINAL = frozenset({PREEMPTED, SUCCEEDED, ABORTED, REJECTED, RECALLED, LOST})
"""GoalStatus values after which a goal never changes again."""


class ActionTransport(Protocol):
    """What the action classes need from a connection: publish and subscribe by topic."""

    @property
    def registry(self) -> MessageRegistry:
        """Message classes of the connection."""
        ...

    def advertise(self, topic: str, msg_type: str, latch: bool = False) -> Callable[[Any], None]:
        """Start publishing on `topic`; returns the publish function."""
        ...

    def subscribe(self, topic: str, msg_type: str, callback: Callable[[Any], None]) -> None:
        """Call `callback(msg)` for every message on `topic`."""
        ...


def _stamp(registry: MessageRegistry, seconds: float) -> Any:
    total = round(seconds * 1e9)
    return registry.msg_class("time")(sec=total // 10**9, nanosec=total % 10**9)


def _seconds(stamp: Any) -> float:
    return float(stamp.sec) + float(stamp.nanosec) * 1e-9


class ServerGoal:
    """One goal on the server side; the handler moves it through actionlib's states."""

    def __init__(self, server: ActionServerCore, goal_id: str, stamp: float, goal: Any) -> None:
        self.server, self.id, self.stamp, self.goal = server, goal_id, stamp, goal
        self.status = PENDING
        self.text = ""
        self.ended_at: float | None = None

    @property
    def cancel_requested(self) -> bool:
        """True once a cancel request reached this goal (RECALLING or PREEMPTING)."""
        return self.status in (RECALLING, PREEMPTING)

    def _move(self, allowed: dict[int, int], what: str, text: str = "") -> None:
        with self.server._lock:
            if self.status not in allowed:
                raise MessageError(
                    f"action {self.server.name!r} goal {self.id!r}: cannot {what} in status "
                    f"{self.status}"
                )
            self.status, self.text = allowed[self.status], text
            if self.status in TERMINAL:
                self.ended_at = time.monotonic()
        self.server._publish_status()

    def accept(self, text: str = "") -> None:
        """PENDING -> ACTIVE (RECALLING -> PREEMPTING: the cancel still stands)."""
        self._move({PENDING: ACTIVE, RECALLING: PREEMPTING}, "accept", text)

    def reject(self, result: Any = None, text: str = "") -> None:
        """Refuse a goal not yet accepted."""
        self._move({PENDING: REJECTED, RECALLING: REJECTED}, "reject", text)
        self.server._publish_result(self, result)

    def succeed(self, result: Any = None, text: str = "") -> None:
        """The goal was reached."""
        self._move({ACTIVE: SUCCEEDED, PREEMPTING: SUCCEEDED}, "succeed", text)
        self.server._publish_result(self, result)

    def abort(self, result: Any = None, text: str = "") -> None:
        """The goal failed."""
        self._move({ACTIVE: ABORTED, PREEMPTING: ABORTED}, "abort", text)
        self.server._publish_result(self, result)

    def canceled(self, result: Any = None, text: str = "") -> None:
        """Stopped on request or by preemption: RECALLED before acceptance, else PREEMPTED."""
        self._move(
            {PENDING: RECALLED, RECALLING: RECALLED, ACTIVE: PREEMPTED, PREEMPTING: PREEMPTED},
            "cancel",
            text,
        )
        self.server._publish_result(self, result)

    def publish_feedback(self, feedback: Any) -> None:
        """Send feedback for this goal."""
        self.server._publish_feedback(self, feedback)


class ActionServerCore:
    """Serves action `name` of type `action_type` (e.g. control_msgs/FollowJointTrajectory).

    `on_goal(goal)` runs for every new goal (PENDING; it accepts or rejects, now or later);
    `on_cancel(goal)` when a cancel request reaches a goal still running. Status goes out
    at `status_rate` Hz and on every change; finished goals stay in it `keep_s` seconds.
    """

    def __init__(
        self,
        transport: ActionTransport,
        name: str,
        action_type: str,
        on_goal: Callable[[ServerGoal], None],
        on_cancel: Callable[[ServerGoal], None] | None = None,
        *,
        clock: Callable[[], float] = time.time,
        status_rate: float = 5.0,
        keep_s: float = 5.0,
    ) -> None:
        self.name, self.action_type = name.rstrip("/"), action_type
        self.registry = transport.registry
        self.on_goal, self.on_cancel, self.clock = on_goal, on_cancel, clock
        self.keep_s = keep_s
        self.goals: dict[str, ServerGoal] = {}
        self._lock = threading.RLock()
        self._last_cancel = 0.0
        self._ids = itertools.count(1)
        reg = self.registry
        self._status_pub = transport.advertise(
            f"{self.name}/status", "actionlib_msgs/GoalStatusArray"
        )
        self._feedback_pub = transport.advertise(
            f"{self.name}/feedback", f"{action_type}ActionFeedback"
        )
        self._result_pub = transport.advertise(f"{self.name}/result", f"{action_type}ActionResult")
        self._classes = {
            k: reg.msg_class(t)
            for k, t in {
                "status": "actionlib_msgs/GoalStatus",
                "array": "actionlib_msgs/GoalStatusArray",
                "id": "actionlib_msgs/GoalID",
                "feedback": f"{action_type}ActionFeedback",
                "result": f"{action_type}ActionResult",
            }.items()
        }
        transport.subscribe(f"{self.name}/goal", f"{action_type}ActionGoal", self._on_goal)
        transport.subscribe(f"{self.name}/cancel", "actionlib_msgs/GoalID", self._on_cancel)
        self._stop = threading.Event()
        self._period = 1.0 / status_rate
        self._thread = threading.Thread(
            target=self._status_loop, name=f"action{self.name}", daemon=True
        )
        self._thread.start()

    def close(self) -> None:
        """Stop publishing status (the transport's registrations are its owner's)."""
        self._stop.set()
        self._thread.join(2)

    def _header(self) -> Any:
        return self.registry.new("std_msgs/Header", stamp=_stamp(self.registry, self.clock()))

    def _status_msg(self, goal: ServerGoal) -> Any:
        goal_id = self._classes["id"](stamp=_stamp(self.registry, goal.stamp), id=goal.id)
        return self._classes["status"](goal_id=goal_id, status=goal.status, text=goal.text)

    def _publish_status(self) -> None:
        now = time.monotonic()
        with self._lock:
            for key in [
                k
                for k, g in self.goals.items()
                if g.ended_at is not None and now - g.ended_at > self.keep_s
            ]:
                del self.goals[key]
            statuses = [self._status_msg(g) for g in self.goals.values()]
        self._status_pub(self._classes["array"](header=self._header(), status_list=statuses))

    def _status_loop(self) -> None:
        while not self._stop.wait(self._period):
            try:
                self._publish_status()
            except Exception:  # a closed connection: keep trying until closed
                _log.debug("status of %s not published", self.name, exc_info=True)

    def _publish_result(self, goal: ServerGoal, result: Any) -> None:
        body = result if result is not None else self.registry.new(f"{self.action_type}Result")
        self._result_pub(
            self._classes["result"](
                header=self._header(), status=self._status_msg(goal), result=body
            )
        )

    def _publish_feedback(self, goal: ServerGoal, feedback: Any) -> None:
        self._feedback_pub(
            self._classes["feedback"](
                header=self._header(), status=self._status_msg(goal), feedback=feedback
            )
        )

    def _on_goal(self, msg: Any) -> None:
        goal_id = str(msg.goal_id.id)
        stamp = _seconds(msg.goal_id.stamp)
        with self._lock:
            if goal_id in self.goals:
                return  # a repeated goal: actionlib ignores it
            goal = ServerGoal(
                self,
                goal_id or f"{self.name}-{next(self._ids)}-{self.clock():.6f}",
                stamp or self.clock(),
                msg.goal,
            )
            self.goals[goal.id] = goal
            recalled = stamp != 0.0 and stamp <= self._last_cancel
        if recalled:  # a cancel for every goal up to this stamp came first
            goal.status = RECALLING
            goal.canceled(text="canceled before it arrived")
            return
        self.on_goal(goal)

    def _on_cancel(self, msg: Any) -> None:
        cancel_id, stamp = str(msg.id), _seconds(msg.stamp)
        hit = []
        with self._lock:
            self._last_cancel = max(self._last_cancel, stamp)
            for goal in self.goals.values():
                match = (not cancel_id and stamp == 0.0) or goal.id == cancel_id
                match = match or (stamp != 0.0 and goal.stamp <= stamp)
                if match and goal.status in (PENDING, ACTIVE):
                    goal.status = RECALLING if goal.status == PENDING else PREEMPTING
                    hit.append(goal)
        if hit:
            self._publish_status()
        for goal in hit:
            if self.on_cancel is not None:
                self.on_cancel(goal)


class ClientGoal:
    """A goal sent by an `ActionClientCore`: its latest status, feedback and result."""

    def __init__(self, client: ActionClientCore, goal_id: str) -> None:
        self.client, self.id = client, goal_id
        self.status: int | None = None
        self.text = ""
        self.result: Any = None
        self.feedback: Any = None
        self.on_feedback: Callable[[Any], None] | None = None
        self._done = threading.Event()

    @property
    def done(self) -> bool:
        """True once the result arrived."""
        return self._done.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the result arrives; False on timeout."""
        return self._done.wait(timeout)

    def cancel(self) -> None:
        """Ask the server to cancel this goal."""
        self.client._send_cancel(self.id, 0.0)


class ActionClientCore:
    """Sends goals to action `name` and follows their status, feedback and result."""

    def __init__(
        self,
        transport: ActionTransport,
        name: str,
        action_type: str,
        *,
        clock: Callable[[], float] = time.time,
        client_name: str = "simbridge",
    ) -> None:
        self.name, self.action_type = name.rstrip("/"), action_type
        self.registry, self.clock, self.client_name = transport.registry, clock, client_name
        self.goals: dict[str, ClientGoal] = {}
        self._lock = threading.Lock()
        self._ids = itertools.count(1)
        self._server_seen = threading.Event()
        self._goal_pub = transport.advertise(f"{self.name}/goal", f"{action_type}ActionGoal")
        self._cancel_pub = transport.advertise(f"{self.name}/cancel", "actionlib_msgs/GoalID")
        self._classes = {
            "goal": self.registry.msg_class(f"{action_type}ActionGoal"),
            "id": self.registry.msg_class("actionlib_msgs/GoalID"),
        }
        transport.subscribe(
            f"{self.name}/status", "actionlib_msgs/GoalStatusArray", self._on_status
        )
        transport.subscribe(
            f"{self.name}/feedback", f"{action_type}ActionFeedback", self._on_feedback
        )
        transport.subscribe(f"{self.name}/result", f"{action_type}ActionResult", self._on_result)

    def wait_for_server(self, timeout: float | None = None) -> bool:
        """True once the server's status topic was heard from (as actionlib decides)."""
        return self._server_seen.wait(timeout)

    def send_goal(self, goal: Any, on_feedback: Callable[[Any], None] | None = None) -> ClientGoal:
        """Send `goal` (a `<Action>Goal` message); feedback goes to `on_feedback`."""
        now = self.clock()
        goal_id = f"/{self.client_name}-{next(self._ids)}-{now:.6f}"
        handle = ClientGoal(self, goal_id)
        handle.on_feedback = on_feedback
        with self._lock:
            self.goals[goal_id] = handle
        stamp = _stamp(self.registry, now)
        self._goal_pub(
            self._classes["goal"](
                header=self.registry.new("std_msgs/Header", stamp=stamp),
                goal_id=self._classes["id"](stamp=stamp, id=goal_id),
                goal=goal,
            )
        )
        return handle

    def cancel_all(self) -> None:
        """Cancel every goal on the server (an empty GoalID)."""
        self._send_cancel("", 0.0)

    def cancel_before(self, seconds: float) -> None:
        """Cancel every goal stamped at or before `seconds`."""
        self._send_cancel("", seconds)

    def _send_cancel(self, goal_id: str, seconds: float) -> None:
        stamp = _stamp(self.registry, seconds)
        self._cancel_pub(self._classes["id"](stamp=stamp, id=goal_id))

    def _on_status(self, msg: Any) -> None:
        self._server_seen.set()
        with self._lock:
            for status in msg.status_list:
                handle = self.goals.get(str(status.goal_id.id))
                if handle is not None and not handle.done:
                    handle.status, handle.text = int(status.status), str(status.text)

    def _on_feedback(self, msg: Any) -> None:
        handle = self.goals.get(str(msg.status.goal_id.id))
        if handle is None:
            return
        handle.feedback = msg.feedback
        if handle.on_feedback is not None:
            handle.on_feedback(msg.feedback)

    def _on_result(self, msg: Any) -> None:
        with self._lock:
            handle = self.goals.pop(str(msg.status.goal_id.id), None)
        if handle is None:
            return
        handle.status, handle.text = int(msg.status.status), str(msg.status.text)
        handle.result = msg.result
        handle._done.set()
