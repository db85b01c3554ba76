"""A connector's `Ros2ActionServer` against a fake endpoint that announces `action_servers`:
the frames it sends for each goal transition, requests for actions it does not serve, and
its registration replayed on a new connection (the old connection's goals forgotten)."""

from __future__ import annotations

import queue
from collections.abc import Iterator
from typing import Any

import pytest

from simbridge.connector import (
    ActionServer,
    Connector,
    Ros2ActionServer,
    Ros2ServerGoal,
    action_server,
)
from simbridge.messages import ros2_registry
from simbridge.messages.actionlib import ACTIVE, PREEMPTED, PREEMPTING, REJECTED
from simbridge.protocol import (
    STATUS_ABORTED,
    STATUS_CANCELED,
    CommandReceived,
    ServeAction,
    ServedAccept,
    ServedCancelRequest,
    ServedFeedback,
    ServedGoalRequest,
    ServedResult,
)
from tests.connector.conftest import FAST
from tests.connector.fake_endpoint import FakeEndpoint

REG = ros2_registry()
GRIPPER = "control_msgs/GripperCommand"


def _goal(position: float) -> bytes:
    command = REG.new("control_msgs/GripperCommand", position=position, max_effort=1.0)
    return REG.encode(REG.new(f"{GRIPPER}Goal", command=command), fmt="cdr")


def _sent(ep: FakeEndpoint, conn: int = -1) -> list[Any]:
    return [e.command for e in ep.events(conn) if isinstance(e, CommandReceived)]


def _served(ep: FakeEndpoint) -> list[Any]:
    """The answers, feedback and results sent so far."""
    return [c for c in _sent(ep) if isinstance(c, ServedAccept | ServedFeedback | ServedResult)]


@pytest.fixture
def ep() -> Iterator[FakeEndpoint]:
    with FakeEndpoint(keepalive=0.2, protocol="ROS2", extensions=["action_servers"]) as fake:
        yield fake


def test_goal_transitions_become_frames(ep: FakeEndpoint) -> None:
    goals: queue.Queue[Ros2ServerGoal] = queue.Queue()
    cancels: queue.Queue[Ros2ServerGoal] = queue.Queue()
    with Connector("127.0.0.1", ep.port, FAST, registry=REG).connect() as ros:
        server = action_server(ros, "/grip", GRIPPER, goals.put, cancels.put)
        assert isinstance(server, Ros2ActionServer)
        assert ep.wait_for(lambda: ServeAction("/grip", GRIPPER) in _sent(ep))
        ep.send_all(ServedGoalRequest(5, "/grip", _goal(0.5)).encode())
        goal = goals.get(timeout=60)
        assert (goal.id, goal.goal.command.position) == (5, 0.5)
        goal.accept()
        assert goal.status == ACTIVE
        goal.publish_feedback(REG.new(f"{GRIPPER}Feedback", position=0.25))
        ep.send_all(ServedCancelRequest(5).encode())
        assert cancels.get(timeout=60) is goal
        assert goal.status == PREEMPTING
        goal.canceled(REG.new(f"{GRIPPER}Result", position=0.3))
        assert goal.status == PREEMPTED
        ep.send_all(ServedGoalRequest(6, "/elsewhere", _goal(0.1)).encode())  # not served
        ep.send_all(ServedGoalRequest(7, "/grip", _goal(0.1)).encode())
        refused = goals.get(timeout=60)
        refused.reject(REG.new(f"{GRIPPER}Result", stalled=True), text="no")
        assert refused.status == REJECTED
        assert ep.wait_for(lambda: len(_served(ep)) >= 6)
        frames = _served(ep)
    assert frames[0] == ServedAccept(5, True)
    assert isinstance(frames[1], ServedFeedback)
    assert REG.decode(frames[1].feedback, f"{GRIPPER}Feedback", fmt="cdr").position == 0.25
    assert (frames[2].goal_id, frames[2].status) == (5, STATUS_CANCELED)
    assert REG.decode(frames[2].result, f"{GRIPPER}Result", fmt="cdr").position == 0.3
    assert frames[3] == ServedAccept(6, False)
    # A rejection with a result reaches a ROS 2 client as accepted, then aborted with it.
    assert frames[4] == ServedAccept(7, True)
    assert (frames[5].goal_id, frames[5].status) == (7, STATUS_ABORTED)
    assert REG.decode(frames[5].result, f"{GRIPPER}Result", fmt="cdr").stalled is True
    assert len(frames) == 6


def test_reconnect_serves_again_and_forgets_the_old_goals(ep: FakeEndpoint) -> None:
    goals: queue.Queue[Ros2ServerGoal] = queue.Queue()
    with Connector("127.0.0.1", ep.port, FAST, registry=REG).connect() as ros:
        server = Ros2ActionServer(ros, "/grip", GRIPPER, goals.put)
        assert ep.wait_for(lambda: ServeAction("/grip", GRIPPER) in _sent(ep))
        ep.send_all(ServedGoalRequest(1, "/grip", _goal(0.5)).encode())
        old = goals.get(timeout=60)
        old.accept()
        assert ep.wait_for(lambda: ServedAccept(1, True) in _sent(ep))
        ep.live_conns()[0].close()  # the endpoint aborts the goals of a connection that goes
        assert ep.wait_conns(2)
        assert ep.wait_for(lambda: ServeAction("/grip", GRIPPER) in _sent(ep, 1))
        assert ep.wait_for(lambda: old.lost)
        old.succeed()  # a no-op now: nothing is sent for a goal of the old connection
        assert server.goals == {}
        server.close()
        assert ep.wait_for(lambda: any(c.NAME == "__action_unserve" for c in _sent(ep, 1)))
        assert not any(isinstance(c, ServedResult) for c in _sent(ep, 1))


def test_action_server_picks_actionlib_on_a_ros1_endpoint() -> None:
    with (
        FakeEndpoint(keepalive=0.2) as ros1,
        Connector("127.0.0.1", ros1.port, FAST).connect() as ros,
    ):
        server = action_server(ros, "/grip", GRIPPER, lambda _goal: None)
        try:
            assert isinstance(server, ActionServer)
        finally:
            server.close()
