"""ROS 2 actions for sim-side clients (the `actions` extension), against real rclpy action
servers in other processes (tests/ros2/ros2_node.py `fibonacci`).

The first tests speak the extension's frames by hand (RawClient); the last ones use the
connector's `Ros2ActionClient`. CDR goals and results come from rosbags' Jazzy store
with test_msgs/action/Fibonacci registered from tests/assets, not from the endpoint.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from tests.endpoint.rawclient import RawClient
from tests.ros2support import Ros2Process, require_ros2, start_endpoint

from simbridge.connector import Connector, Ros2ActionClient, action_client
from simbridge.messages import ROS2_STORE, MessageRegistry
from simbridge.messages.actionlib import LOST, PREEMPTED, REJECTED, SUCCEEDED
from simbridge.protocol import (
    ACTIONS_EXTENSION,
    STATUS_ACCEPTED,
    STATUS_CANCELED,
    STATUS_CANCELING,
    STATUS_SUCCEEDED,
    ActionCancel,
    ActionFeedback,
    ActionGoal,
    ActionResult,
    ActionServerQuery,
    ActionServerReply,
    ActionStatus,
    CommandReceived,
    ErrorMessage,
    Handshake,
)

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(240)]

ASSETS = Path(__file__).parents[3] / "assets" / "ros2_actions"
FIB = "test_msgs/Fibonacci"


def registry() -> MessageRegistry:
    reg = MessageRegistry(store=ROS2_STORE)
    reg.load_packages(ASSETS)
    return reg


REG = registry()


def goal_cdr(order: int) -> bytes:
    return REG.encode(REG.new("test_msgs/FibonacciGoal", order=order), fmt="cdr")


def sequence(payload: bytes, part: str) -> list[int]:
    return [int(v) for v in REG.decode(payload, f"test_msgs/Fibonacci{part}", fmt="cdr").sequence]


def command(event: object, cls: type, goal_id: int | None = None) -> bool:
    return (
        isinstance(event, CommandReceived)
        and isinstance(event.command, cls)
        and (goal_id is None or getattr(event.command, "goal_id", None) == goal_id)
    )


def tails(*procs: Ros2Process) -> str:
    """The last output lines of the endpoint and servers, for a failed wait's message."""
    return "\n".join("".join(p.output[-15:]) for p in procs)


def unique_action() -> str:
    return f"/fib_{os.getpid()}_{time.monotonic_ns() % 10**9}"


@pytest.fixture(scope="module")
def endpoint() -> Iterator[tuple[Ros2Process, int]]:
    require_ros2()
    proc, port = start_endpoint("--idle-timeout", "0")
    try:
        yield proc, port
    finally:
        proc.stop()


@pytest.fixture
def client(endpoint: tuple[Ros2Process, int]) -> Iterator[RawClient]:
    raw = RawClient(endpoint[1])
    try:
        yield raw
    finally:
        raw.close()


def server(action: str, period: float = 0.05, *flags: str) -> Ros2Process:
    proc = Ros2Process.node("fibonacci", action, str(period), *flags)
    proc.expect_json("ready", timeout=60)
    return proc


def wait_ready(client: RawClient, action: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        client.send(ActionServerQuery(action, FIB).encode())
        reply = client.expect(lambda e: command(e, ActionServerReply), timeout=10)
        if reply.command.ready:
            return
        time.sleep(0.1)
    raise AssertionError(f"no action server for {action} within {timeout} s")


def test_handshake_announces_actions(endpoint: tuple[Ros2Process, int]) -> None:
    raw = RawClient(endpoint[1])
    try:
        event = raw.expect(lambda e: command(e, Handshake))
        assert ACTIONS_EXTENSION in event.command.metadata["extensions"]
    finally:
        raw.close()


def test_goal_feedback_result(client: RawClient) -> None:
    action = unique_action()
    with server(action) as srv:
        wait_ready(client, action)
        client.send(ActionGoal(1, action, FIB, goal_cdr(5)).encode())
        status = client.expect(lambda e: command(e, ActionStatus, 1), timeout=20)
        assert status.command.status == STATUS_ACCEPTED
        feedback = client.expect(lambda e: command(e, ActionFeedback, 1), timeout=20)
        assert sequence(feedback.command.feedback, "Feedback") == [0, 1, 1]
        result = client.expect(lambda e: command(e, ActionResult, 1), timeout=20)
        assert result.command.status == STATUS_SUCCEEDED
        assert sequence(result.command.result, "Result") == [0, 1, 1, 2, 3, 5]
        assert srv.expect_json("goal") == 5


def test_cancel_a_running_goal(client: RawClient) -> None:
    action = unique_action()
    with server(action, 0.2) as srv:
        wait_ready(client, action)
        client.send(ActionGoal(2, action, FIB, goal_cdr(50)).encode())
        client.expect(lambda e: command(e, ActionFeedback, 2), timeout=20)
        client.send(ActionCancel(2).encode())
        canceling = client.expect(
            lambda e: command(e, ActionStatus, 2) and e.command.status == STATUS_CANCELING,
            timeout=20,
        )
        assert canceling
        result = client.expect(lambda e: command(e, ActionResult, 2), timeout=20)
        assert result.command.status == STATUS_CANCELED
        assert len(sequence(result.command.result, "Result")) < 50
        assert srv.expect_json("canceled") == 50


def test_rejected_goal_gets_an_error(client: RawClient) -> None:
    action = unique_action()
    with server(action, 0.05, "--reject") as srv:
        wait_ready(client, action)
        client.send(ActionGoal(3, action, FIB, goal_cdr(4)).encode())
        error = client.expect(lambda e: command(e, ErrorMessage, 3), timeout=20)
        assert "rejected" in error.command.text
        assert action in error.command.text
        assert srv.expect_json("rejected") == 4


def test_no_server_fails_within_the_discovery_wait(client: RawClient) -> None:
    action = unique_action()
    client.send(ActionGoal(4, action, FIB, goal_cdr(4)).encode())
    # the endpoint's discovery wait ends it: only that answer comes before this timeout
    error = client.expect(lambda e: command(e, ErrorMessage, 4), timeout=60)
    assert "no ROS 2 action server" in error.command.text
    assert action in error.command.text


def test_unknown_action_type_names_it(client: RawClient) -> None:
    client.send(ActionGoal(5, "/fib", "test_msgs/NoSuchAction", b"").encode())
    error = client.expect(lambda e: command(e, ErrorMessage, 5), timeout=20)
    assert "test_msgs/action/NoSuchAction" in error.command.text
    client.send(ActionServerQuery("/fib", "nope_msgs/Nope").encode())
    error = client.expect(lambda e: command(e, ErrorMessage), timeout=20)
    assert "nope_msgs" in error.command.text
    reply = client.expect(lambda e: command(e, ActionServerReply), timeout=20)
    assert reply.command.ready is False


def test_goal_that_is_not_cdr_of_the_goal_type(client: RawClient) -> None:
    action = unique_action()
    with server(action):
        wait_ready(client, action)
        client.send(ActionGoal(6, action, FIB, b"\x01").encode())
        error = client.expect(lambda e: command(e, ErrorMessage, 6), timeout=20)
        assert "not a CDR" in error.command.text


def test_disconnect_cancels_the_clients_goals(endpoint: tuple[Ros2Process, int]) -> None:
    action = unique_action()
    with server(action, 0.2) as srv:
        raw = RawClient(endpoint[1])
        try:
            wait_ready(raw, action)
            raw.send(ActionGoal(7, action, FIB, goal_cdr(60)).encode())
            raw.expect(lambda e: command(e, ActionFeedback, 7), timeout=20)
        finally:
            raw.close()
        assert srv.expect_json("canceled", timeout=20) == 60
        endpoint[0].expect_line(r"cancelled its 1 action goal", timeout=20)


def test_goals_in_flight_are_bounded(endpoint: tuple[Ros2Process, int]) -> None:
    """The default bound is 100 goals; the 101st is refused, counted in __stats."""
    action = unique_action()
    with server(action, 0.5):
        raw = RawClient(endpoint[1])
        try:
            wait_ready(raw, action)
            for goal_id in range(100, 201):
                raw.send(ActionGoal(goal_id, action, FIB, goal_cdr(100)).encode())
            error = raw.expect(lambda e: command(e, ErrorMessage, 200), timeout=60)
            assert "limit 100" in error.command.text
            stats = raw.stats(timeout=20)
            assert stats["session"]["goals_sent"] == 101
            assert stats["session"]["goals_refused"] == 1
        finally:
            raw.close()


# ---- through the connector ------------------------------------------------------------


@pytest.fixture
def ros(endpoint: tuple[Ros2Process, int]) -> Iterator[Connector]:
    with Connector("127.0.0.1", endpoint[1], registry=REG).connect() as connector:
        yield connector


def test_connector_goal_feedback_result(ros: Connector, endpoint: tuple[Ros2Process, int]) -> None:
    """Feedback travels on a topic and the result on a service: DDS orders neither against
    the other, and a feedback published before the endpoint's subscription matched the
    server's publisher is lost. So the goal runs for seconds (feedback comes), and each
    feedback is checked to be a longer prefix of the result than the one before."""
    action = unique_action()
    with server(action, 0.3) as srv:
        client = action_client(ros, action, FIB)
        assert isinstance(client, Ros2ActionClient)
        assert client.wait_for_server(30)
        feedback: list[list[int]] = []
        goal = client.send_goal(
            REG.new("test_msgs/FibonacciGoal", order=12),
            on_feedback=lambda fb: feedback.append([int(v) for v in fb.sequence]),
        )
        assert goal.wait(60), (goal.status, goal.text, feedback, tails(endpoint[0], srv))
        assert goal.status == SUCCEEDED
        assert goal.ros2_status == STATUS_SUCCEEDED
        result = [int(v) for v in goal.result.sequence]
        assert result == [0, 1, 1, 2, 3, 5, 8, 13, 21, 34, 55, 89, 144]
        assert feedback, tails(endpoint[0], srv)
        assert all(3 <= len(fb) <= len(result) and fb == result[: len(fb)] for fb in feedback)
        assert [len(fb) for fb in feedback] == sorted({len(fb) for fb in feedback})  # in order
        assert goal.text == ""
        assert not client.goals


def test_connector_cancel(ros: Connector, endpoint: tuple[Ros2Process, int]) -> None:
    action = unique_action()
    with server(action, 0.5) as srv:  # 20 s to run: the cancel comes long before the end
        client = Ros2ActionClient(ros, action, FIB)
        assert client.wait_for_server(30)
        got_feedback = threading.Event()
        goal = client.send_goal(
            REG.new("test_msgs/FibonacciGoal", order=40), on_feedback=lambda _fb: got_feedback.set()
        )
        assert got_feedback.wait(60), (goal.status, goal.text, tails(endpoint[0], srv))
        goal.cancel()
        assert goal.wait(60), (goal.status, goal.text, tails(endpoint[0], srv))
        assert goal.status == PREEMPTED
        assert goal.ros2_status == STATUS_CANCELED
        assert len(goal.result.sequence) < 41
        assert srv.expect_json("canceled") == 40


def test_connector_rejected_and_no_server(ros: Connector) -> None:
    action = unique_action()
    with server(action, 0.05, "--reject"):
        client = Ros2ActionClient(ros, action, FIB)
        assert client.wait_for_server(30)
        goal = client.send_goal(REG.new("test_msgs/FibonacciGoal", order=3))
        assert goal.wait(30)
        assert goal.status == REJECTED
        assert goal.ros2_status is None
        assert "rejected" in goal.text
        assert goal.result is None
    nobody = Ros2ActionClient(ros, unique_action(), FIB)
    start = time.monotonic()
    assert not nobody.wait_for_server(0.5)
    goal = nobody.send_goal(REG.new("test_msgs/FibonacciGoal", order=3))
    assert goal.wait(20)
    assert time.monotonic() - start < 15
    assert goal.status == REJECTED
    assert "no ROS 2 action server" in goal.text


def test_connector_close_cancels_its_goals(endpoint: tuple[Ros2Process, int]) -> None:
    action = unique_action()
    with server(action, 0.2) as srv:
        ros = Connector("127.0.0.1", endpoint[1], registry=REG).connect()
        try:
            client = Ros2ActionClient(ros, action, FIB)
            assert client.wait_for_server(30)
            running = threading.Event()
            goal = client.send_goal(
                REG.new("test_msgs/FibonacciGoal", order=70), on_feedback=lambda _f: running.set()
            )
            assert running.wait(30)
        finally:
            ros.close()
        assert goal.done
        assert goal.status == LOST
        assert "connector closed" in goal.text
        assert srv.expect_json("canceled", timeout=20) == 70


def test_server_that_leaves_mid_goal_ends_it_with_an_error(ros: Connector) -> None:
    action = unique_action()
    srv = server(action, 0.2)
    try:
        client = Ros2ActionClient(ros, action, FIB)
        assert client.wait_for_server(30)
        running = threading.Event()
        goal = client.send_goal(
            REG.new("test_msgs/FibonacciGoal", order=80), on_feedback=lambda _f: running.set()
        )
        assert running.wait(30)
    finally:
        srv.stop()
    assert goal.wait(60)  # the endpoint ends it once discovery sees the server gone
    assert goal.status == LOST
    assert "left the graph" in goal.text


def test_stopping_the_endpoint_cancels_running_goals() -> None:
    require_ros2()
    action = unique_action()
    with server(action, 0.2) as srv:
        proc, port = start_endpoint("--idle-timeout", "0")
        try:
            raw = RawClient(port)
            wait_ready(raw, action)
            raw.send(ActionGoal(1, action, FIB, goal_cdr(60)).encode())
            raw.expect(lambda e: command(e, ActionFeedback, 1), timeout=20)
        finally:
            proc.stop()
            raw.close()
        assert srv.expect_json("canceled", timeout=20) == 60


def test_stopping_waits_for_a_silent_server_only_so_long() -> None:
    """A server that cannot answer its goal's cancel (stopped) holds the endpoint's exit up
    by the close wait (2 s), not longer, and the endpoint says so."""
    require_ros2()
    action = unique_action()
    with server(action, 0.2) as srv:
        proc, port = start_endpoint("--idle-timeout", "0")
        raw = RawClient(port)
        try:
            wait_ready(raw, action)
            raw.send(ActionGoal(1, action, FIB, goal_cdr(60)).encode())
            raw.expect(lambda e: command(e, ActionFeedback, 1), timeout=20)
            os.killpg(srv.proc.pid, signal.SIGSTOP)
            started = time.monotonic()
            proc.stop(timeout=15)
            took = time.monotonic() - started
        finally:
            os.killpg(srv.proc.pid, signal.SIGCONT)
            proc.stop()
            raw.close()
    assert proc.proc.returncode == 0, tails(proc)
    assert 1.5 <= took < 8, tails(proc)
    assert any("did not answer a cancel within 2 s" in line for line in proc.output), tails(proc)


def test_two_clients_share_an_action_and_keep_their_own_goals(
    endpoint: tuple[Ros2Process, int],
) -> None:
    """Goal ids are per client (both use 1); one client leaving cancels only its goal."""
    action = unique_action()
    with server(action, 0.1) as srv:
        first, second = RawClient(endpoint[1]), RawClient(endpoint[1])
        try:
            wait_ready(first, action)
            wait_ready(second, action)
            first.send(ActionGoal(1, action, FIB, goal_cdr(60)).encode())
            first.expect(lambda e: command(e, ActionFeedback, 1), timeout=20)
            second.send(ActionGoal(1, action, FIB, goal_cdr(8)).encode())
            second.expect(lambda e: command(e, ActionStatus, 1), timeout=20)
            first.close()
            assert srv.expect_json("canceled", timeout=20) == 60
            result = second.expect(lambda e: command(e, ActionResult, 1), timeout=30)
            assert result.command.status == STATUS_SUCCEEDED
            assert sequence(result.command.result, "Result")[-1] == 21
        finally:
            first.close()
            second.close()
