"""The `actions` extension's commands: golden frames, round trips, validation."""

from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from simbridge.errors import ProtocolError
from simbridge.protocol import (
    STATUS_ACCEPTED,
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
    ProtocolConnection,
    decode_command,
)

# test_msgs/action/Fibonacci Goal {order: 5} in CDR: encapsulation header, then int32 5.
FIB_GOAL = b"\x00\x01\x00\x00\x05\x00\x00\x00"


def test_golden_action_goal() -> None:
    frame = ActionGoal(7, "/fibonacci", "test_msgs/Fibonacci", FIB_GOAL).encode()
    body = (
        b'{"goal_id": 7, "action": "/fibonacci", "action_type": "test_msgs/Fibonacci", '
        b'"goal": "AAEAAAUAAAA="}'
    )
    assert frame == b"\x0d\x00\x00\x00__action_goal" + len(body).to_bytes(4, "little") + body
    assert decode_command("__action_goal", body, sender="client") == ActionGoal(
        7, "/fibonacci", "test_msgs/Fibonacci", FIB_GOAL
    )


def test_golden_endpoint_frames() -> None:
    assert ActionStatus(7, STATUS_ACCEPTED).encode() == (
        b'\x0f\x00\x00\x00__action_status\x1b\x00\x00\x00{"goal_id": 7, "status": 1}'
    )
    body = b'{"goal_id": 7, "status": 4, "result": "AAEAAAIAAAAAAAAAAQAAAA=="}'
    result = b"\x00\x01\x00\x00\x02\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\x00"
    assert ActionResult(7, STATUS_SUCCEEDED, result).encode() == (
        b"\x0f\x00\x00\x00__action_result" + len(body).to_bytes(4, "little") + body
    )
    assert (
        ErrorMessage("rejected", goal_id=7).encode().endswith(b'{"text": "rejected", "goal_id": 7}')
    )
    assert ActionCancel(7).encode() == (
        b'\x0f\x00\x00\x00__action_cancel\x0e\x00\x00\x00{"goal_id": 7}'
    )


def test_server_query_and_reply_share_a_name() -> None:
    query = ActionServerQuery("/fibonacci", "test_msgs/action/Fibonacci")
    reply = ActionServerReply("/fibonacci", True)
    assert query.NAME == reply.NAME == "__action_server"
    assert ProtocolConnection("endpoint").receive_data(query.encode()) == [CommandReceived(query)]
    assert ProtocolConnection("client").receive_data(reply.encode()) == [CommandReceived(reply)]


@pytest.mark.parametrize(
    ("name", "body", "needle"),
    [
        ("__action_goal", b'{"goal_id": -1, "action": "/a", "action_type": "p/A"}', "goal_id"),
        ("__action_goal", b'{"goal_id": 1, "action": "a b", "action_type": "p/A"}', "whitespace"),
        ("__action_goal", b'{"goal_id": 1, "action": "/a", "action_type": "p/A/B/C"}', "type"),
        (
            "__action_goal",
            b'{"goal_id": 1, "action": "/a", "action_type": "p/A", "goal": "%%%"}',
            "not valid base64",
        ),
        ("__action_goal", b'{"goal_id": 1, "action": "/a", "action_type": "p/A", "goal": 5}', "5"),
        ("__action_cancel", b'{"goal_id": "7"}', "integer"),
    ],
)
def test_bad_client_commands_name_the_problem(name: str, body: bytes, needle: str) -> None:
    with pytest.raises(ProtocolError, match=needle):
        decode_command(name, body, sender="client")


def test_endpoint_statuses_are_checked() -> None:
    with pytest.raises(ProtocolError, match="status 4 is not one of 1, 2, 3"):
        decode_command("__action_status", b'{"goal_id": 1, "status": 4}', sender="endpoint")
    with pytest.raises(ProtocolError, match="status 2 is not one of 4, 5, 6"):
        decode_command(
            "__action_result", b'{"goal_id": 1, "status": 2, "result": ""}', sender="endpoint"
        )


def test_directions_are_kept_apart() -> None:
    with pytest.raises(ProtocolError, match="unknown system command"):
        decode_command("__action_result", b"{}", sender="client")
    with pytest.raises(ProtocolError, match="unknown system command"):
        decode_command("__action_goal", b"{}", sender="endpoint")


@given(
    st.integers(0, 2**63 - 1),
    st.from_regex(r"/[a-z][a-z0-9_]{0,20}", fullmatch=True),
    st.binary(max_size=200),
)
def test_round_trips(goal_id: int, action: str, payload: bytes) -> None:
    client_side = ProtocolConnection("endpoint")
    endpoint_side = ProtocolConnection("client")
    goal = ActionGoal(goal_id, action, "test_msgs/Fibonacci", payload)
    assert client_side.receive_data(goal.encode()) == [CommandReceived(goal)]
    assert client_side.receive_data(ActionCancel(goal_id).encode()) == [
        CommandReceived(ActionCancel(goal_id))
    ]
    for command in (
        ActionFeedback(goal_id, payload),
        ActionResult(goal_id, STATUS_SUCCEEDED, payload),
        ActionStatus(goal_id, STATUS_ACCEPTED),
        ErrorMessage(f"goal {goal_id} rejected", goal_id=goal_id),
    ):
        assert endpoint_side.receive_data(command.encode()) == [CommandReceived(command)]


_JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner),
    max_leaves=12,
)
_KEYS = ("goal_id", "action", "action_type", "goal", "status", "feedback", "result", "ready")


@given(
    st.sampled_from(
        [
            ("__action_goal", "client"),
            ("__action_cancel", "client"),
            ("__action_server", "client"),
            ("__action_server", "endpoint"),
            ("__action_status", "endpoint"),
            ("__action_feedback", "endpoint"),
            ("__action_result", "endpoint"),
        ]
    ),
    st.dictionaries(st.sampled_from(_KEYS), _JSON, max_size=8),
)
def test_fuzz_decoders_refuse_or_round_trip(which: tuple[str, str], obj: object) -> None:
    """Any JSON object is refused with a ProtocolError, or decodes to a command whose own
    frame decodes to the same command again."""
    name, sender = which
    try:
        command = decode_command(name, json.dumps(obj).encode(), sender=sender)  # type: ignore[arg-type]
    except ProtocolError:
        return
    assert name == command.NAME
    receiver = ProtocolConnection("endpoint" if sender == "client" else "client")
    assert receiver.receive_data(command.encode()) == [CommandReceived(command)]
