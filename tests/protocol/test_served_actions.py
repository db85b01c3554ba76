"""The `action_servers` extension's commands: golden frames, round trips, validation."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from simbridge.errors import ProtocolError
from simbridge.protocol import (
    STATUS_CANCELED,
    STATUS_SUCCEEDED,
    CommandReceived,
    ProtocolConnection,
    ServeAction,
    ServedAccept,
    ServedCancelRequest,
    ServedFeedback,
    ServedGoalRequest,
    ServedResult,
    UnserveAction,
    decode_command,
)

# control_msgs/action/GripperCommand Goal {position 0.5, max_effort 2.0} in CDR.
GRIP_GOAL = b"\x00\x01\x00\x00" + struct.pack("<dd", 0.5, 2.0)
ARM = "/arm/arm_controller/follow_joint_trajectory"


def _frame(name: bytes, body: bytes) -> bytes:
    return len(name).to_bytes(4, "little") + name + len(body).to_bytes(4, "little") + body


def test_golden_client_frames() -> None:
    assert ServeAction(ARM, "control_msgs/FollowJointTrajectory").encode() == _frame(
        b"__action_serve",
        b'{"action": "/arm/arm_controller/follow_joint_trajectory", '
        b'"action_type": "control_msgs/FollowJointTrajectory"}',
    )
    assert UnserveAction(ARM).encode() == _frame(
        b"__action_unserve", b'{"action": "/arm/arm_controller/follow_joint_trajectory"}'
    )
    assert ServedAccept(3, True).encode() == (
        b'\x0f\x00\x00\x00__action_accept\x20\x00\x00\x00{"goal_id": 3, "accepted": true}'
    )
    assert ServedFeedback(3, b"\x00\x01\x00\x00").encode() == _frame(
        b"__action_serve_feedback", b'{"goal_id": 3, "feedback": "AAEAAA=="}'
    )
    assert ServedResult(3, STATUS_CANCELED, b"\x00\x01\x00\x00").encode() == _frame(
        b"__action_serve_result", b'{"goal_id": 3, "status": 5, "result": "AAEAAA=="}'
    )


def test_golden_endpoint_frames() -> None:
    assert ServedGoalRequest(3, "/grip", GRIP_GOAL).encode() == _frame(
        b"__action_request",
        b'{"goal_id": 3, "action": "/grip", "goal": "AAEAAAAAAAAAAOA/AAAAAAAAAEA="}',
    )
    assert ServedCancelRequest(3).encode() == (
        b'\x17\x00\x00\x00__action_cancel_request\x0e\x00\x00\x00{"goal_id": 3}'
    )
    assert decode_command(
        "__action_request",
        b'{"goal_id": 3, "action": "/grip", "goal": "AAEAAAAAAAAAAOA/AAAAAAAAAEA="}',
        sender="endpoint",
    ) == ServedGoalRequest(3, "/grip", GRIP_GOAL)


@pytest.mark.parametrize(
    ("name", "body", "needle"),
    [
        ("__action_serve", b'{"action": "", "action_type": "p/A"}', "blank"),
        ("__action_serve", b'{"action": "/a", "action_type": "p/A/B/C"}', "type"),
        ("__action_unserve", b'{"action": 5}', "5"),
        ("__action_accept", b'{"goal_id": 1, "accepted": "yes"}', "true or false"),
        ("__action_accept", b'{"goal_id": -2, "accepted": true}', "goal_id"),
        ("__action_serve_feedback", b'{"goal_id": 1, "feedback": "%%"}', "not valid base64"),
        ("__action_serve_result", b'{"goal_id": 1, "status": 2, "result": ""}', "4, 5, 6"),
        ("__action_serve_result", b'{"goal_id": 1, "status": 1, "result": ""}', "status 1"),
    ],
)
def test_bad_client_commands_name_the_problem(name: str, body: bytes, needle: str) -> None:
    with pytest.raises(ProtocolError, match=needle):
        decode_command(name, body, sender="client")


def test_directions_are_kept_apart() -> None:
    with pytest.raises(ProtocolError, match="unknown system command"):
        decode_command("__action_request", b"{}", sender="client")
    with pytest.raises(ProtocolError, match="unknown system command"):
        decode_command("__action_accept", b"{}", sender="endpoint")


@given(
    st.integers(0, 2**63 - 1),
    st.from_regex(r"/[a-z][a-z0-9_]{0,20}", fullmatch=True),
    st.binary(max_size=200),
    st.booleans(),
)
def test_round_trips(goal_id: int, action: str, payload: bytes, accepted: bool) -> None:
    at_endpoint = ProtocolConnection("endpoint")
    at_client = ProtocolConnection("client")
    for command in (
        ServeAction(action, "control_msgs/GripperCommand"),
        UnserveAction(action),
        ServedAccept(goal_id, accepted),
        ServedFeedback(goal_id, payload),
        ServedResult(goal_id, STATUS_SUCCEEDED, payload),
    ):
        assert at_endpoint.receive_data(command.encode()) == [CommandReceived(command)]
    for reply in (ServedGoalRequest(goal_id, action, payload), ServedCancelRequest(goal_id)):
        assert at_client.receive_data(reply.encode()) == [CommandReceived(reply)]
