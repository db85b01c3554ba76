"""ROS 2 action servers run by a client (the `action_servers` extension), speaking the
extension's frames by hand (RawClient) to a `--backend ros2` endpoint, with a plain rclpy
ActionClient in another process (tests/ros2/action_driver.py) sending the goals."""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from tests.endpoint.rawclient import RawClient
from tests.ros2.action_rig import ActionRig, action_rig

from simbridge.messages import ROS2_STORE, MessageRegistry
from simbridge.protocol import (
    ACTION_SERVERS_EXTENSION,
    STATUS_ABORTED,
    STATUS_CANCELED,
    STATUS_SUCCEEDED,
    CommandReceived,
    ErrorMessage,
    Handshake,
    ServeAction,
    ServedAccept,
    ServedCancelRequest,
    ServedFeedback,
    ServedGoalRequest,
    ServedResult,
    UnserveAction,
)

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(240)]

ASSETS = Path(__file__).parents[3] / "assets" / "ros2_actions"
FIB = "test_msgs/Fibonacci"
FIB_ROS2 = "test_msgs/action/Fibonacci"
REG = MessageRegistry(store=ROS2_STORE)
REG.load_packages(ASSETS)


def cdr(part: str, **fields: object) -> bytes:
    return REG.encode(REG.new(f"{FIB}{part}", **fields), fmt="cdr")


def is_command(event: object, cls: type) -> bool:
    return isinstance(event, CommandReceived) and isinstance(event.command, cls)


def unique_action() -> str:
    return f"/served_fib_{os.getpid()}_{time.monotonic_ns() % 10**9}"


@pytest.fixture(scope="module")
def rig() -> Iterator[ActionRig]:
    yield from action_rig()


@pytest.fixture
def served(rig: ActionRig) -> Iterator[tuple[RawClient, str]]:
    """A raw client serving a new Fibonacci action, which the driver has found."""
    raw = RawClient(rig.port)
    action = unique_action()
    try:
        handshake = raw.expect(lambda e: is_command(e, Handshake)).command
        assert ACTION_SERVERS_EXTENSION in handshake.metadata["extensions"]
        raw.send(ServeAction(action, FIB).encode())
        rig.driver.wait_ready(action, FIB_ROS2)
        yield raw, action
    finally:
        raw.close()


def next_goal(raw: RawClient) -> ServedGoalRequest:
    request = raw.expect(lambda e: is_command(e, ServedGoalRequest), timeout=60).command
    assert isinstance(request, ServedGoalRequest)
    return request


def test_goal_feedback_result_and_rejection(served: tuple[RawClient, str], rig: ActionRig) -> None:
    raw, action = served
    driver = rig.driver
    driver.goal("fib", {"order": 4}, action=action, kind=FIB_ROS2)
    request = next_goal(raw)
    assert request.action == action
    assert REG.decode(request.goal, f"{FIB}Goal", fmt="cdr").order == 4
    raw.send(ServedAccept(request.goal_id, True).encode())
    assert driver.reply("accepted", "fib")["ok"] is True
    raw.send(ServedFeedback(request.goal_id, cdr("Feedback", sequence=[0, 1])).encode())
    raw.send(
        ServedResult(
            request.goal_id, STATUS_SUCCEEDED, cdr("Result", sequence=[0, 1, 1, 2])
        ).encode()
    )
    result = driver.reply("result", "fib")
    assert (result["status"], result["values"]["sequence"]) == (STATUS_SUCCEEDED, [0, 1, 1, 2])
    driver.goal("no", {"order": 1}, action=action, kind=FIB_ROS2)
    raw.send(ServedAccept(next_goal(raw).goal_id, False).encode())
    assert driver.reply("accepted", "no")["ok"] is False
    session = raw.stats()["session"]
    assert (session["served_goals"], session["served_goals_rejected"]) == (2, 1)
    assert session["served_goals_aborted"] == 0


def test_cancel_request_and_preemption(served: tuple[RawClient, str], rig: ActionRig) -> None:
    raw, action = served
    driver = rig.driver
    driver.goal("asked", {"order": 9}, action=action, kind=FIB_ROS2)
    first = next_goal(raw)
    raw.send(ServedAccept(first.goal_id, True).encode())
    assert driver.reply("accepted", "asked")["ok"] is True
    driver.send(op="cancel", tag="asked")
    cancel = raw.expect(lambda e: is_command(e, ServedCancelRequest), timeout=60).command
    assert cancel == ServedCancelRequest(first.goal_id)
    assert driver.reply("cancel", "asked")["canceling"] == 1
    raw.send(ServedResult(first.goal_id, STATUS_CANCELED, cdr("Result")).encode())
    assert driver.reply("result", "asked")["status"] == STATUS_CANCELED
    # A preemption: the client cancels a goal nobody asked to cancel.
    driver.goal("old", {"order": 9}, action=action, kind=FIB_ROS2)
    old = next_goal(raw)
    raw.send(ServedAccept(old.goal_id, True).encode())
    assert driver.reply("accepted", "old")["ok"] is True
    raw.send(ServedResult(old.goal_id, STATUS_CANCELED, cdr("Result", sequence=[0])).encode())
    assert driver.reply("result", "old")["status"] == STATUS_CANCELED


def test_bad_frames_get_errors_and_the_connection_stays(
    served: tuple[RawClient, str], rig: ActionRig
) -> None:
    raw, action = served
    driver = rig.driver

    def error() -> str:
        return str(raw.expect(lambda e: is_command(e, ErrorMessage), timeout=60).command.text)

    raw.send(ServedAccept(777, True).encode())
    assert "goal 777 is not a goal of an action this client serves" in error()
    driver.goal("bad", {"order": 3}, action=action, kind=FIB_ROS2)
    request = next_goal(raw)
    raw.send(ServedResult(request.goal_id, STATUS_SUCCEEDED, b"").encode())
    assert "the result for goal" in error()  # not accepted yet
    raw.send(ServedAccept(request.goal_id, True).encode())
    assert driver.reply("accepted", "bad")["ok"] is True
    raw.send(ServedResult(request.goal_id, STATUS_SUCCEEDED, b"\x00\x01\x00\x00\xff").encode())
    assert "is not a CDR" in error()
    other = RawClient(rig.port)
    try:
        other.send(ServeAction(action, FIB).encode())
        text = str(other.expect(lambda e: is_command(e, ErrorMessage), timeout=60).command.text)
        assert "already served by another client" in text
    finally:
        other.close()
    raw.send(UnserveAction(action).encode())  # the goal still running is aborted
    assert driver.reply("result", "bad")["status"] == STATUS_ABORTED
    raw.send(UnserveAction(action).encode())
    assert "is not served by this client" in error()
    session = raw.stats()["session"]
    assert session["errors_sent"] == 4
    assert (session["served_goals"], session["served_goals_aborted"]) == (1, 1)


def test_the_client_leaving_aborts_its_goals(served: tuple[RawClient, str], rig: ActionRig) -> None:
    raw, action = served
    driver = rig.driver
    driver.goal("left", {"order": 5}, action=action, kind=FIB_ROS2)
    raw.send(ServedAccept(next_goal(raw).goal_id, True).encode())
    assert driver.reply("accepted", "left")["ok"] is True
    raw.close()
    assert driver.reply("result", "left")["status"] == STATUS_ABORTED
