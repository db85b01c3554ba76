"""actionlib's goal state machine under arbitrary sequences of handler calls and cancel
requests: only legal transitions happen, terminal states never change, and every goal
ends with exactly one result (property test over an in-memory transport)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.errors import MessageError
from simbridge.messages import MessageRegistry, default_registry
from simbridge.messages.actionlib import (
    ACTIVE,
    PENDING,
    PREEMPTING,
    RECALLING,
    TERMINAL,
    ActionServerCore,
    ServerGoal,
)

REG = default_registry()
ACTION = "control_msgs/GripperCommand"
LEGAL = {
    PENDING: {ACTIVE, RECALLING, 5, 8},
    RECALLING: {PREEMPTING, 5, 8},
    ACTIVE: {PREEMPTING, 2, 3, 4},
    PREEMPTING: {2, 3, 4},
}


class Wire:
    """Topics in memory: what a server publishes, and a way to deliver to it."""

    def __init__(self) -> None:
        self.sent: list[tuple[str, Any]] = []
        self.handlers: dict[str, Callable[[Any], None]] = {}

    @property
    def registry(self) -> MessageRegistry:
        return REG

    def advertise(self, topic: str, msg_type: str, latch: bool = False) -> Callable[[Any], None]:
        return lambda msg: self.sent.append((topic, msg))

    def subscribe(self, topic: str, msg_type: str, callback: Callable[[Any], None]) -> None:
        self.handlers[topic] = callback


ACTIONS = st.lists(
    st.tuples(
        st.sampled_from(["accept", "reject", "succeed", "abort", "canceled", "cancel_req"]),
        st.integers(0, 2),
    ),
    max_size=25,
)


@settings(max_examples=150, deadline=None)
@given(ACTIONS)
def test_transitions_are_legal_and_terminal_is_final(steps: list[tuple[str, int]]) -> None:
    wire = Wire()
    goals: list[ServerGoal] = []
    server = ActionServerCore(wire, "/g", ACTION, goals.append, status_rate=0.01)
    try:
        for i in range(3):
            goal_id = REG.new("actionlib_msgs/GoalID", id=f"g{i}")
            wire.handlers["/g/goal"](REG.new(f"{ACTION}ActionGoal", goal_id=goal_id))
        assert [g.status for g in goals] == [PENDING] * 3
        for action, index in steps:
            goal = goals[index]
            before = goal.status
            if action == "cancel_req":
                wire.handlers["/g/cancel"](REG.new("actionlib_msgs/GoalID", id=goal.id))
            else:
                try:
                    getattr(goal, action)()
                except MessageError:
                    assert goal.status == before  # refused: nothing changed
                    continue
            if before in TERMINAL:
                assert goal.status == before
            elif goal.status != before:
                assert goal.status in LEGAL[before], (before, action, goal.status)
        results = [m.status.goal_id.id for t, m in wire.sent if t == "/g/result"]
        for goal in goals:
            assert results.count(goal.id) == (1 if goal.status in TERMINAL else 0)
    finally:
        server.close()


def test_repeated_goal_ids_are_ignored_and_cancel_by_stamp_recalls_later_arrivals() -> None:
    wire = Wire()
    goals: list[ServerGoal] = []
    server = ActionServerCore(wire, "/g", ACTION, goals.append, status_rate=0.01)
    try:
        stamp = REG.msg_class("time")(sec=100, nanosec=0)
        first = REG.new("actionlib_msgs/GoalID", id="a", stamp=stamp)
        wire.handlers["/g/goal"](REG.new(f"{ACTION}ActionGoal", goal_id=first))
        wire.handlers["/g/goal"](REG.new(f"{ACTION}ActionGoal", goal_id=first))
        assert len(goals) == 1
        # Cancel everything stamped up to t=200, then a goal stamped 150 arrives late.
        wire.handlers["/g/cancel"](
            REG.new("actionlib_msgs/GoalID", stamp=REG.msg_class("time")(sec=200, nanosec=0))
        )
        assert goals[0].status == RECALLING
        late = REG.new(
            "actionlib_msgs/GoalID", id="b", stamp=REG.msg_class("time")(sec=150, nanosec=0)
        )
        wire.handlers["/g/goal"](REG.new(f"{ACTION}ActionGoal", goal_id=late))
        assert len(goals) == 1  # never handed to the handler
        assert server.goals["b"].status == 8  # RECALLED
    finally:
        server.close()


@pytest.mark.parametrize("bad", ["x", "-1"])
def test_server_names_the_goal_in_refusals(bad: str) -> None:
    wire = Wire()
    goals: list[ServerGoal] = []
    server = ActionServerCore(wire, "/g", ACTION, goals.append, status_rate=0.01)
    try:
        wire.handlers["/g/goal"](
            REG.new(f"{ACTION}ActionGoal", goal_id=REG.new("actionlib_msgs/GoalID", id=bad))
        )
        with pytest.raises(MessageError, match=f"action '/g' goal '{bad}': cannot succeed"):
            goals[0].succeed()
    finally:
        server.close()
