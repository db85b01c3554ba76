"""System commands: golden JSON frames, validation errors, connection state."""

from __future__ import annotations

import json
import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from simbridge.errors import ProtocolError
from simbridge.protocol import (
    CommandReceived,
    ErrorMessage,
    Handshake,
    KeepaliveReceived,
    MessageReceived,
    ProtocolConnection,
    ProtocolViolation,
    Publish,
    RemoveSubscriber,
    ServiceRequestHeader,
    ServiceRequestReceived,
    ServiceResponseReceived,
    Subscribe,
    TopicListReply,
    TopicListRequest,
    decode_command,
    encode_frame,
)


def test_golden_handshake() -> None:
    frame = Handshake().encode()
    body = b'{"version": "v0.7.0", "metadata": "{\\"protocol\\": \\"ROS1\\"}"}'
    assert frame == (
        b"\x0b\x00\x00\x00"  # destination length 11
        b"__handshake"  # system command name
        + len(body).to_bytes(4, "little")  # payload length
        + body  # JSON object; metadata is itself a JSON string
    )
    decoded = decode_command("__handshake", body, sender="endpoint")
    assert isinstance(decoded, Handshake)
    assert decoded.version == "v0.7.0"
    assert decoded.protocol == "ROS1"


def test_golden_publish_from_unity_json() -> None:
    # What Unity's JsonUtility writes for a RosPublisher registration.
    body = b'{"topic":"/pos_rot","message_name":"geometry_msgs/Pose","queue_size":10,"latch":false}'
    assert decode_command("__publish", body, sender="client") == Publish(
        "/pos_rot", "geometry_msgs/Pose", 10, False
    )


def test_ros2_json_with_trailing_nul() -> None:
    body = b'{"topic":"/odom","message_name":"nav_msgs/Odometry"}\x00'
    assert decode_command("__subscribe", body, sender="client") == Subscribe(
        "/odom", "nav_msgs/Odometry"
    )


@pytest.mark.parametrize(
    ("name", "body", "needle"),
    [
        ("__publish", b"{not json", "not valid JSON"),
        ("__publish", b"[1, 2]", "JSON object"),
        ("__publish", b'{"topic": "", "message_name": "std_msgs/String"}', "blank"),
        ("__publish", b'{"topic": "/a", "message_name": 5}', "'message_name' must be a string"),
        ("__publish", b'{"topic": "/a", "message_name": "x/Y", "queue_size": "9"}', "integer"),
        ("__publish", b'{"topic": "/a", "message_name": "x/Y", "latch": 1}', "true or false"),
        ("__request", b'{"srv_id": true}', "integer"),
        ("__no_such", b"{}", "unknown system command '__no_such'"),
        ("__handshake", b"{}", "unknown system command"),
    ],
)
def test_bad_commands_name_the_problem(name: str, body: bytes, needle: str) -> None:
    with pytest.raises(ProtocolError, match=needle.replace("[", r"\[")):
        decode_command(name, body, sender="client")


def test_unknown_command_lists_valid_ones() -> None:
    with pytest.raises(ProtocolError) as info:
        decode_command("__getattribute__", b"{}", sender="client")
    assert "__subscribe" in str(info.value)


def test_service_header_pairs_with_next_frame() -> None:
    conn = ProtocolConnection("endpoint")
    data = (
        ServiceRequestHeader(7).encode()
        + encode_frame("/add", b"\x01\x02")
        + encode_frame("/topic", b"m")
    )
    assert conn.receive_data(data) == [
        ServiceRequestReceived(7, "/add", b"\x01\x02"),
        MessageReceived("/topic", b"m"),
    ]


def test_response_header_on_client_side() -> None:
    conn = ProtocolConnection("client")
    data = ProtocolConnection.service_response(3, "/svc", b"ok")
    assert conn.receive_data(data) == [ServiceResponseReceived(3, "/svc", b"ok")]


def test_header_followed_by_command_is_reported() -> None:
    conn = ProtocolConnection("endpoint")
    events = conn.receive_data(ServiceRequestHeader(1).encode() + TopicListRequest().encode())
    assert isinstance(events[0], ProtocolViolation)
    assert "srv_id=1" in events[0].text
    assert events[1] == CommandReceived(TopicListRequest())


def test_keepalive_and_remove_commands() -> None:
    conn = ProtocolConnection("endpoint")
    events = conn.receive_data(ProtocolConnection.keepalive() + RemoveSubscriber("/x").encode())
    assert events == [KeepaliveReceived(), CommandReceived(RemoveSubscriber("/x"))]


def test_oversized_frame_is_fatal_violation() -> None:
    conn = ProtocolConnection("endpoint", max_payload=10)
    events = conn.receive_data(b"\x01\x00\x00\x00t\xff\xff\xff\x7f")
    assert len(events) == 1
    assert isinstance(events[0], ProtocolViolation)
    assert events[0].fatal
    assert conn.receive_data(b"anything") == []


def test_error_with_srv_id_round_trip() -> None:
    frame = ErrorMessage("no provider", srv_id=1001).encode()
    events = ProtocolConnection("client").receive_data(frame)
    assert events == [CommandReceived(ErrorMessage("no provider", 1001))]


def test_topic_list_reply_must_pair_up() -> None:
    body = json.dumps({"topics": ["/a", "/b"], "types": ["std_msgs/String"]}).encode()
    with pytest.raises(ProtocolError, match="pair up"):
        decode_command("__topic_list", body, sender="endpoint")
    reply = TopicListReply(("/a",), ("std_msgs/String",))
    assert ProtocolConnection("client").receive_data(reply.encode()) == [CommandReceived(reply)]


@given(st.binary(max_size=500))
def test_fuzz_connection_yields_only_events(data: bytes) -> None:
    conn = ProtocolConnection("endpoint", max_payload=1000)
    for event in conn.receive_data(data):
        assert isinstance(
            event,
            KeepaliveReceived
            | MessageReceived
            | CommandReceived
            | ServiceRequestReceived
            | ServiceResponseReceived
            | ProtocolViolation,
        )


_NAME_ORACLE = re.compile(r"[~/A-Za-z_][A-Za-z0-9_/]*", re.ASCII)
_TYPE_ORACLE = re.compile(r"[A-Za-z]\w*(/[A-Za-z]\w*){0,2}", re.ASCII)


def _valid_name(text: str) -> bool:
    return (
        bool(_NAME_ORACLE.fullmatch(text))
        and "//" not in text
        and text not in ("/", "~")
        and len(text) <= 256
    )


@given(
    st.text(max_size=40) | st.from_regex(r"/[a-z_]{1,10}(/[a-z0-9]{1,5})?", fullmatch=True),
    st.text(max_size=40) | st.from_regex(r"[a-z]{1,8}/[A-Z][a-z]{0,8}", fullmatch=True),
    st.integers(-(2**40), 2**40),
    st.booleans(),
)
def test_fuzz_publish_json(topic: str, msg: str, queue: int, latch: bool) -> None:
    body = json.dumps({"topic": topic, "message_name": msg, "queue_size": queue, "latch": latch})
    topic, msg = topic.rstrip("\x00"), msg.rstrip("\x00")
    valid = (
        _valid_name(topic) and bool(_TYPE_ORACLE.fullmatch(msg)) and len(msg) <= 256 and queue >= 0
    )
    try:
        cmd = decode_command("__publish", body.encode(), sender="client")
    except ProtocolError:
        assert not valid
        return
    assert valid
    assert cmd == Publish(topic, msg, min(queue, 1_000_000), latch)


# Input that used to escape as an exception (and drop the connection without an __error).
_CLIENT_TOPIC_COMMANDS = [
    "__subscribe",
    "__publish",
    "__ros_service",
    "__unity_service",
    "__remove_subscriber",
    "__remove_publisher",
    "__remove_ros_service",
    "__remove_unity_service",
]


@pytest.mark.parametrize("name", _CLIENT_TOPIC_COMMANDS)
@pytest.mark.parametrize("topic", ["/\ud800", "/caf\u00e9", "/a b", "/a//b", "/", "/" + "a" * 300])
def test_invalid_names_refused_at_decode_in_every_command(name: str, topic: str) -> None:
    body = json.dumps({"topic": topic, "message_name": "std_msgs/String"}).encode()
    with pytest.raises(ProtocolError, match=re.escape(name)) as info:
        decode_command(name, body, sender="client")
    assert len(str(info.value)) < 400  # the echoed name is shortened


@pytest.mark.parametrize(
    ("body", "needle"),
    [
        (b"[" * 100_000, "nested too deeply"),
        (b'{"a": ' * 100_000, "nested too deeply"),
        (b'{"topic": "/a", "message_name": "x/Y", "queue_size": ' + b"9" * 5000 + b"}", "digits"),
        (b'{"topic": "/a", "message_name": "x/Y", "queue_size": -1}', "must be in 0.."),
        (b'{"topic": "/a", "message_name": "x y/Z"}', "whitespace"),
        (b'{"topic": "/a", "message_name": "' + b"x/Y" * 100 + b'"}', "longer than 256"),
        (b'{"topic": "/a", "message_name": "\\ud800/X"}', "surrogate"),
        (b'{"topic": "/a", "message_name": "' + b"x" * (1 << 20) + b'"}', "exceeds"),
    ],
)
def test_hostile_json_is_a_protocol_error(body: bytes, needle: str) -> None:
    with pytest.raises(ProtocolError, match=re.escape(needle)):
        decode_command("__subscribe", body, sender="client")


def test_subscribe_carries_its_queue_size() -> None:
    # The endpoint's send queue for the client is this long; it was once left out, so a
    # Connector asking for 310 got the default 100 and lost images it meant to keep.
    command = Subscribe("/img", "sensor_msgs/Image", 310)
    body = command.encode()[8 + len(Subscribe.NAME) :]
    assert json.loads(body)["queue_size"] == 310
    assert decode_command("__subscribe", body, sender="client") == command
    # The default keeps the bytes Unity's ROS-TCP-Connector sends.
    assert b"queue_size" not in Subscribe("/odom", "nav_msgs/Odometry").encode()


def test_queue_size_is_capped() -> None:
    body = b'{"topic": "/a", "message_name": "x/Y", "queue_size": 1000000000}'
    assert decode_command("__subscribe", body, sender="client") == Subscribe("/a", "x/Y", 1_000_000)
    assert decode_command("__publish", body, sender="client") == Publish("/a", "x/Y", 1_000_000)


def test_hostile_command_in_stream_is_a_violation_and_stream_continues() -> None:
    conn = ProtocolConnection("endpoint")
    bad = encode_frame("__subscribe", b"[" * 100_000)
    good = Subscribe("/ok", "std_msgs/String").encode()
    events = conn.receive_data(bad + good)
    assert isinstance(events[0], ProtocolViolation)
    assert not events[0].fatal
    assert "__subscribe" in events[0].text
    assert events[1] == CommandReceived(Subscribe("/ok", "std_msgs/String"))
