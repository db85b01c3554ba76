"""Fuzzing a live endpoint over real sockets: any mix of valid and broken frames leaves it
serving, answers every bad frame, and never closes a connection without a fatal reason."""

from __future__ import annotations

import json
import struct
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.protocol import (
    CommandReceived,
    ErrorMessage,
    ProtocolConnection,
    Publish,
    RosService,
    Subscribe,
    TopicListReply,
    TopicListRequest,
    UnityService,
    encode_frame,
)
from tests.endpoint.rawclient import RawClient

TOPICS = st.sampled_from(["/a", "/b", "", " ", "/svc", "__x"])
TYPES = st.sampled_from(["std_msgs/String", "std_srvs/Trigger", "nope/Nothing", "", "x"])
JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers() | st.text(max_size=10),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner, max_size=3)
    ),
    max_leaves=6,
)

FRAMES = st.one_of(
    st.builds(lambda t, m: Publish(t, m).encode(), TOPICS, TYPES),
    st.builds(lambda t, m: Subscribe(t, m).encode(), TOPICS, TYPES),
    st.builds(lambda t, m: RosService(t, m).encode(), TOPICS, TYPES),
    st.builds(lambda t, m: UnityService(t, m).encode(), TOPICS, TYPES),
    st.builds(encode_frame, TOPICS, st.binary(max_size=40)),
    st.builds(
        lambda i, t, p: ProtocolConnection.service_request(i, t or "/svc", p),
        st.integers(0, 2**31),
        TOPICS,
        st.binary(max_size=16),
    ),
    st.builds(
        lambda i, t: ProtocolConnection.service_response(i, t or "/svc", b""),
        st.integers(0, 2**31),
        TOPICS,
    ),
    st.builds(
        lambda name, obj: encode_frame(name, json.dumps(obj).encode()),
        st.sampled_from(
            [
                "__publish",
                "__subscribe",
                "__request",
                "__response",
                "__topic_list",
                "__remove_publisher",
                "__stats",
                "__unknown",
                "__error",
            ]
        ),
        JSON_VALUES,
    ),
    st.builds(encode_frame, st.just("__publish"), st.binary(max_size=30)),
)


@pytest.fixture(scope="module")
def endpoint() -> Iterator[EndpointThread]:
    with EndpointThread(EndpointOptions(port=0, service_timeout=1.0)) as ep:
        yield ep


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(frames=st.lists(FRAMES, min_size=1, max_size=12))
def test_any_frame_sequence_leaves_the_endpoint_serving(
    endpoint: EndpointThread, frames: list[bytes]
) -> None:
    client = RawClient(endpoint.port)
    try:
        client.send(b"".join(frames) + TopicListRequest().encode())
        # Well-framed input never costs the connection: the topic list still comes back.
        client.expect(
            lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
        )
    finally:
        client.close()
    other = RawClient(endpoint.port)
    other.send(TopicListRequest().encode())
    other.expect(lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply))
    other.close()


@settings(
    max_examples=25,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(prefix=st.binary(max_size=64), length=st.integers(2**27, 2**32 - 1))
def test_broken_framing_gets_an_error_then_close(
    endpoint: EndpointThread, prefix: bytes, length: int
) -> None:
    client = RawClient(endpoint.port)
    try:
        client.send(struct.pack("<I", 2) + b"/x" + struct.pack("<I", length) + prefix)
        error = client.expect(
            lambda e: isinstance(e, CommandReceived) and isinstance(e.command, ErrorMessage)
        )
        assert str(length) in error.command.text
        assert client.closed_by_peer()
    finally:
        client.close()
