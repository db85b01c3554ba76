"""Hostile input over real sockets: every bad command gets an `__error`, never a silent drop."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from benchmarks.attacks import EndpointProcess

from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.protocol import (
    CommandReceived,
    ErrorMessage,
    Handshake,
    Publish,
    Subscribe,
    TopicListReply,
    TopicListRequest,
    encode_frame,
)
from tests.endpoint.rawclient import RawClient

TOPIC_COMMANDS = [
    "__subscribe",
    "__publish",
    "__ros_service",
    "__unity_service",
    "__remove_subscriber",
    "__remove_publisher",
    "__remove_ros_service",
    "__remove_unity_service",
]


@pytest.fixture(scope="module")
def endpoint() -> Iterator[EndpointThread]:
    with EndpointThread(EndpointOptions(port=0, warn_interval=0.0)) as ep:
        yield ep


@pytest.fixture
def client(endpoint: EndpointThread) -> Iterator[RawClient]:
    c = RawClient(endpoint.port)
    c.expect(lambda e: isinstance(e, CommandReceived) and isinstance(e.command, Handshake))
    yield c
    c.close()


def _error(client: RawClient) -> str:
    event = client.expect(
        lambda e: isinstance(e, CommandReceived) and isinstance(e.command, ErrorMessage)
    )
    return str(event.command.text)


def _still_served(client: RawClient) -> None:
    client.send(TopicListRequest().encode())
    client.expect(
        lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
    )


@pytest.mark.parametrize(
    ("command", "payload", "needle"),
    [
        ("__subscribe", b"[" * 100_000, "nested too deeply"),
        ("__publish", b'{"a": ' * 50_000, "nested too deeply"),
        ("__topic_list", b"[" * 100_000, "nested too deeply"),
        (
            "__subscribe",
            b'{"topic": "/a", "message_name": "std_msgs/String", "queue_size": '
            + b"9" * 5000
            + b"}",
            "digits",
        ),
        (
            "__subscribe",
            b'{"topic": "/a", "message_name": "std_msgs/String", "queue_size": -5}',
            "queue_size",
        ),
        ("__request", b'{"srv_id": ' + b"1" * 5000 + b"}", "digits"),
        (
            "__publish",
            b'{"topic": "/a", "message_name": "' + b"std_msgs/Strin" * 70_000 + b'"}',
            "longer than 256",
        ),
    ],
)
def test_hostile_command_gets_error_naming_it_and_connection_survives(
    client: RawClient, command: str, payload: bytes, needle: str
) -> None:
    client.send(encode_frame(command, payload))
    text = _error(client)
    assert command in text
    assert needle in text
    assert len(text) < 1200  # echoed names are shortened
    _still_served(client)


@pytest.mark.parametrize("command", TOPIC_COMMANDS)
def test_lone_surrogate_topic_refused_in_every_command(client: RawClient, command: str) -> None:
    body = json.dumps({"topic": "/\ud800", "message_name": "std_msgs/String"}).encode()
    client.send(encode_frame(command, body))
    text = _error(client)
    assert command in text
    assert "\\ud800" in text
    _still_served(client)
    client.send(TopicListRequest().encode())
    reply = client.expect(
        lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
    )
    assert not any("\ud800" in t for t in reply.command.topics)


def test_message_on_huge_unregistered_topic_is_echoed_shortened(client: RawClient) -> None:
    client.send(encode_frame("/" + "x" * 60_000, b"payload"))
    text = _error(client)
    assert "not registered" in text
    assert len(text) < 1200
    _still_served(client)


def test_bad_user_types_start_fast_and_fail_clearly_at_first_use(tmp_path: Path) -> None:
    pkg = tmp_path / "rec_msgs" / "msg"
    pkg.mkdir(parents=True)
    (pkg / "Tree.msg").write_text("int32 value\nrec_msgs/Tree[] children\n")
    (pkg / "Huge.msg").write_text("".join(f"float64 f{i}\n" for i in range(20_000)))
    start = time.monotonic()
    with EndpointProcess("--msg-path", str(tmp_path)) as ep:
        assert time.monotonic() - start < 30  # eager parsing of Huge alone took longer
        client = RawClient(ep.port)
        client.send(Publish("/tree", "rec_msgs/Tree").encode())
        text = _error(client)
        assert "__publish" in text
        assert "rec_msgs/Tree is recursive" in text
        client.send(Subscribe("/huge", "rec_msgs/Huge").encode())
        text = _error(client)
        assert "__subscribe" in text
        assert "rec_msgs/Huge" in text
        assert "at most" in text
        _still_served(client)
        client.close()
