"""actionlib's protocol on the local bus: the connector's action client and server against
an in-process Node's, both ways (goal, feedback, result, cancel, preemption, recall)."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from simbridge.connector import ActionClient, ActionServer, Connector, ConnectorOptions
from simbridge.endpoint import (
    EndpointOptions,
    EndpointThread,
    LocalBus,
    Node,
    NodeActionClient,
    NodeActionServer,
)
from simbridge.messages import default_registry
from simbridge.messages.actionlib import (
    ABORTED,
    ACTIVE,
    PREEMPTED,
    RECALLED,
    REJECTED,
    SUCCEEDED,
    ActionClientCore,
    ServerGoal,
)
from tests.waiting import wait_for

REG = default_registry()
ACTION = "control_msgs/GripperCommand"


class Gripper:
    """A server handler: accepts goals with max_effort >= 0, finishes on `finish()`,
    rejects negative efforts, aborts position < 0, cancels on request."""

    def __init__(self) -> None:
        self.goals: list[ServerGoal] = []
        self.canceled: list[str] = []

    def on_goal(self, goal: ServerGoal) -> None:
        self.goals.append(goal)
        if goal.goal.command.max_effort < 0:
            goal.reject(text="negative effort")
            return
        if goal.goal.command.max_effort == 99:
            return  # left pending: a cancel recalls it
        goal.accept()
        feedback = REG.new("control_msgs/GripperCommandFeedback", position=0.01)
        goal.publish_feedback(feedback)
        if goal.goal.command.position < 0:
            goal.abort(text="cannot reach a negative gap")

    def on_cancel(self, goal: ServerGoal) -> None:
        self.canceled.append(goal.id)
        goal.canceled(REG.new("control_msgs/GripperCommandResult", position=0.02))

    def finish(self, goal: ServerGoal) -> None:
        goal.succeed(REG.new("control_msgs/GripperCommandResult", position=0.03, reached_goal=True))


def _goal(position: float, effort: float = 1.0) -> Any:
    command = REG.new("control_msgs/GripperCommand", position=position, max_effort=effort)
    return REG.new("control_msgs/GripperCommandGoal", command=command)


@pytest.fixture
def bus() -> Iterator[tuple[Connector, Node]]:
    endpoint = EndpointThread(EndpointOptions(port=0)).start()
    connector = Connector("127.0.0.1", endpoint.port, ConnectorOptions()).connect(wait=5)
    assert isinstance(endpoint.backend, LocalBus)
    node = Node(endpoint.backend, "/tester")
    try:
        yield connector, node
    finally:
        node.close()
        connector.close()
        endpoint.stop()


@pytest.mark.parametrize("server_side", ["node", "connector"])
def test_goal_feedback_result_cancel_reject_abort(
    bus: tuple[Connector, Node], server_side: str
) -> None:
    connector, node = bus
    gripper = Gripper()
    server: Any
    client: Any
    if server_side == "node":
        server = NodeActionServer(
            node, "/grip/gripper_cmd", ACTION, gripper.on_goal, gripper.on_cancel
        )
        client = ActionClient(connector, "/grip/gripper_cmd", ACTION)
    else:
        server = ActionServer(
            connector, "/grip/gripper_cmd", ACTION, gripper.on_goal, gripper.on_cancel
        )
        client = NodeActionClient(node, "/grip/gripper_cmd", ACTION)
    try:
        assert connector.flush(5)
        assert client.wait_for_server(5)  # status heard
        time.sleep(0.2)  # subscriptions settle on both sides
        feedback: list[Any] = []
        done = client.send_goal(_goal(0.03), on_feedback=feedback.append)
        assert wait_for(lambda: len(gripper.goals) == 1)
        assert wait_for(lambda: done.status == ACTIVE)  # from the status topic
        assert wait_for(lambda: bool(feedback))
        assert feedback[0].position == pytest.approx(0.01)
        gripper.finish(gripper.goals[0])
        assert done.wait(5)
        assert done.status == SUCCEEDED
        assert done.result.reached_goal
        assert done.result.position == pytest.approx(0.03)
        assert gripper.goals[0].id == done.id

        running = client.send_goal(_goal(0.02))
        assert wait_for(lambda: running.status == ACTIVE)
        running.cancel()
        assert running.wait(5)
        assert running.status == PREEMPTED
        assert running.result.position == pytest.approx(0.02)
        assert gripper.canceled == [running.id]

        pending = client.send_goal(_goal(0.02, effort=99))  # never accepted
        assert wait_for(lambda: len(gripper.goals) == 3)
        client.cancel_all()
        assert pending.wait(5)
        assert pending.status == RECALLED

        rejected = client.send_goal(_goal(0.02, effort=-1))
        assert rejected.wait(5)
        assert (rejected.status, rejected.text) == (REJECTED, "negative effort")

        aborted = client.send_goal(_goal(-0.1))
        assert aborted.wait(5)
        assert aborted.status == ABORTED
    finally:
        server.close()
        if server_side == "node":
            client.close()


def test_server_goal_rejects_illegal_transitions(bus: tuple[Connector, Node]) -> None:
    _connector, node = bus
    seen: list[ServerGoal] = []
    got = threading.Event()

    def on_goal(goal: ServerGoal) -> None:
        seen.append(goal)
        got.set()

    server = NodeActionServer(node, "/x", ACTION, on_goal)
    try:
        client = NodeActionClient(node, "/x", ACTION)
        time.sleep(0.2)
        client.send_goal(_goal(0.0))
        assert got.wait(5)
        goal = seen[0]
        with pytest.raises(Exception, match="cannot succeed in status 0"):
            goal.succeed()
        goal.accept()
        goal.succeed()
        with pytest.raises(Exception, match="cannot abort in status 3"):
            goal.abort()
    finally:
        server.close()


def test_wait_for_server_waits_for_goal_and_cancel_subscribers(
    bus: tuple[Connector, Node],
) -> None:
    """As actionlib's SimpleActionClient: the status alone is not enough, a goal sent
    before the server subscribed to the goal topic would be lost."""
    connector, node = bus
    client = ActionClient(connector, "/half/gripper_cmd", ACTION)
    status = node.advertise("/half/gripper_cmd/status", "actionlib_msgs/GoalStatusArray")
    stop = threading.Event()

    def beat() -> None:
        while not stop.wait(0.05):
            status.publish(REG.new("actionlib_msgs/GoalStatusArray"))

    beating = threading.Thread(target=beat, daemon=True)
    beating.start()
    try:
        assert connector.flush(5)
        assert ActionClientCore.wait_for_server(client, 5)  # the status was heard
        assert not client.wait_for_server(0.5)  # nobody subscribes the goal or cancel yet
        goals: list[Any] = []
        node.subscribe("/half/gripper_cmd/goal", f"{ACTION}ActionGoal", goals.append)
        assert not client.wait_for_server(0.5)  # still no cancel subscriber
        node.subscribe("/half/gripper_cmd/cancel", "actionlib_msgs/GoalID", lambda _m: None)
        assert client.wait_for_server(5)
        client.send_goal(_goal(0.01))
        assert wait_for(lambda: len(goals) == 1)
    finally:
        stop.set()
        beating.join(5)
        client.close()
