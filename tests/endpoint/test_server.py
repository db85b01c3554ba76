"""The endpoint over real sockets with the local backend: routing, services, bad input."""

from __future__ import annotations

import json
import struct
import time
from collections.abc import Callable, Iterator

import pytest

from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.protocol import (
    CommandReceived,
    ErrorMessage,
    Handshake,
    KeepaliveReceived,
    MessageReceived,
    ProtocolConnection,
    Publish,
    RemovePublisher,
    RemoveSubscriber,
    RosService,
    ServiceRequestHeader,
    ServiceRequestReceived,
    ServiceResponseReceived,
    StatsReply,
    StatsRequest,
    Subscribe,
    TopicListReply,
    TopicListRequest,
    UnityService,
    WarnMessage,
    encode_frame,
)
from tests.endpoint.rawclient import RawClient

TWIST = struct.pack("<6d", 0.5, 0, 0, 0, 0, 0.25)


@pytest.fixture
def endpoint() -> Iterator[EndpointThread]:
    with EndpointThread(EndpointOptions(port=0, keepalive_interval=0.2, service_timeout=2.0)) as ep:
        yield ep


@pytest.fixture
def client(endpoint: EndpointThread) -> Iterator[RawClient]:
    c = RawClient(endpoint.port)
    yield c
    c.close()


def _client(endpoint: EndpointThread) -> RawClient:
    return RawClient(endpoint.port)


def sync(client: RawClient) -> None:
    """Round trip: everything the client sent before is processed."""
    client.send(TopicListRequest().encode())
    client.expect(is_cmd(TopicListReply))


def is_cmd(cls: type) -> Callable[[object], bool]:
    return lambda e: isinstance(e, CommandReceived) and isinstance(e.command, cls)


def error_text(client: RawClient) -> str:
    event = client.expect(is_cmd(ErrorMessage))
    return str(event.command.text)


def test_handshake_first(client: RawClient) -> None:
    event = client.expect(lambda e: True)
    assert isinstance(event, CommandReceived)
    assert isinstance(event.command, Handshake)
    assert event.command.version == "v0.7.0"
    assert event.command.protocol == "ROS1"
    assert event.command.metadata["keepalive"] == 0.2


def test_publish_reaches_every_subscriber(endpoint: EndpointThread) -> None:
    pub, sub1, sub2 = _client(endpoint), _client(endpoint), _client(endpoint)
    for s in (sub1, sub2):
        s.send(Subscribe("/cmd_vel", "geometry_msgs/Twist").encode())
    pub.send(Publish("/cmd_vel", "geometry_msgs/Twist").encode())
    # Registration is processed in order per connection; make sure subscribers are in.
    for s in (sub1, sub2):
        s.send(TopicListRequest().encode())
        s.expect(is_cmd(TopicListReply))
    pub.send(encode_frame("/cmd_vel", TWIST))
    for s in (sub1, sub2):
        event = s.expect(lambda e: isinstance(e, MessageReceived))
        assert event == MessageReceived("/cmd_vel", TWIST)


def test_latched_topic_reaches_late_subscriber(endpoint: EndpointThread) -> None:
    pub = _client(endpoint)
    pub.send(Publish("/map_name", "std_msgs/String", latch=True).encode())
    payload = struct.pack("<I", 3) + b"lab"
    pub.send(encode_frame("/map_name", payload))
    pub.send(TopicListRequest().encode())
    pub.expect(is_cmd(TopicListReply))
    late = _client(endpoint)
    late.send(Subscribe("/map_name", "std_msgs/String").encode())
    assert late.expect(lambda e: isinstance(e, MessageReceived)).payload == payload


def test_topic_list_with_types(client: RawClient) -> None:
    client.send(Publish("/a", "std_msgs/String").encode())
    client.send(Subscribe("/b", "sensor_msgs/Image").encode())
    client.send(TopicListRequest().encode())
    reply = client.expect(is_cmd(TopicListReply)).command
    assert dict(zip(reply.topics, reply.types, strict=True)) == {
        "/a": "std_msgs/String",
        "/b": "sensor_msgs/Image",
    }


def test_remove_subscriber_stops_delivery(endpoint: EndpointThread) -> None:
    pub, sub = _client(endpoint), _client(endpoint)
    sub.send(Subscribe("/x", "std_msgs/Empty").encode())
    sync(sub)
    pub.send(Publish("/x", "std_msgs/Empty").encode())
    pub.send(encode_frame("/x", b""))
    sub.expect(lambda e: isinstance(e, MessageReceived))
    sub.send(RemoveSubscriber("/x").encode())
    sub.send(TopicListRequest().encode())
    sub.expect(is_cmd(TopicListReply))
    pub.send(encode_frame("/x", b""))
    pub.send(TopicListRequest().encode())
    pub.expect(is_cmd(TopicListReply))
    sub.poll(0.3)
    assert not [e for e in sub.events if isinstance(e, MessageReceived)]


def test_service_between_two_clients(endpoint: EndpointThread) -> None:
    server, caller = _client(endpoint), _client(endpoint)
    server.send(UnityService("/enable", "std_srvs/SetBool").encode())
    server.send(TopicListRequest().encode())
    server.expect(is_cmd(TopicListReply))
    caller.send(RosService("/enable", "std_srvs/SetBool").encode())
    caller.send(ProtocolConnection.service_request(5, "/enable", b"\x01"))  # data: true
    request = server.expect(lambda e: isinstance(e, ServiceRequestReceived))
    assert request.srv_id >= 1001
    assert request.payload == b"\x01"
    answer = b"\x01" + struct.pack("<I", 2) + b"on"  # success: true, message: "on"
    server.send(ProtocolConnection.service_response(request.srv_id, "/enable", answer))
    response = caller.expect(lambda e: isinstance(e, ServiceResponseReceived))
    assert response == ServiceResponseReceived(5, "/enable", answer)


def test_service_nobody_implements_answers_with_error(client: RawClient) -> None:
    client.send(RosService("/nobody", "std_srvs/Empty").encode())
    client.send(ProtocolConnection.service_request(9, "/nobody", b""))
    event = client.expect(is_cmd(ErrorMessage))
    assert event.command.srv_id == 9
    assert "/nobody" in event.command.text
    assert "no provider" in event.command.text


def test_service_provider_that_never_answers_times_out(endpoint: EndpointThread) -> None:
    server, caller = _client(endpoint), _client(endpoint)
    server.send(UnityService("/slow", "std_srvs/Empty").encode())
    server.send(TopicListRequest().encode())
    server.expect(is_cmd(TopicListReply))
    caller.send(RosService("/slow", "std_srvs/Empty").encode())
    caller.send(ProtocolConnection.service_request(1, "/slow", b""))
    event = caller.expect(is_cmd(ErrorMessage), timeout=6)
    assert event.command.srv_id == 1
    assert "did not answer" in event.command.text


@pytest.mark.parametrize(
    ("frame", "needle"),
    [
        (encode_frame("__publish", b"{oops"), "not valid JSON"),
        (encode_frame("__explode", b"{}"), "unknown system command '__explode'"),
        (encode_frame("__getattribute__", b"{}"), "unknown system command"),
        (Publish("/t", "no_pkg/Nothing").encode(), "no_pkg/Nothing"),
        (Subscribe("/t", "geometry_msgs/Twistt").encode(), "geometry_msgs/Twist"),
        (
            encode_frame("__subscribe", b'{"topic": " ", "message_name": "std_msgs/String"}'),
            "blank",
        ),
        (encode_frame("/never_registered", b"abc"), "not registered for publishing"),
        (
            encode_frame(
                "__publish",
                json.dumps(
                    {"topic": "/q", "message_name": "std_msgs/String", "queue_size": "x"}
                ).encode(),
            ),
            "integer",
        ),
        (ServiceRequestHeader(4).encode() + encode_frame("/unknown_srv", b""), "__ros_service"),
        (encode_frame("__handshake", b"{}"), "unknown system command"),
    ],
)
def test_bad_input_gets_error_and_connection_survives(
    client: RawClient, frame: bytes, needle: str
) -> None:
    client.send(frame)
    assert needle in error_text(client)
    # Still usable afterwards.
    client.send(Publish("/ok", "std_msgs/String").encode())
    client.send(TopicListRequest().encode())
    assert "/ok" in client.expect(is_cmd(TopicListReply)).command.topics


def test_type_mismatch_on_topic_is_an_error(endpoint: EndpointThread) -> None:
    a, b = _client(endpoint), _client(endpoint)
    a.send(Publish("/same", "std_msgs/String").encode())
    a.send(TopicListRequest().encode())
    a.expect(is_cmd(TopicListReply))
    b.send(Subscribe("/same", "std_msgs/Int32").encode())
    text = error_text(b)
    assert "std_msgs/String" in text
    assert "std_msgs/Int32" in text


def test_huge_length_prefix_closes_without_allocating(endpoint: EndpointThread) -> None:
    client = _client(endpoint)
    client.send(b"\x04\x00\x00\x00/big" + struct.pack("<I", 0xFFFFFFFF))
    text = error_text(client)
    assert "4294967295" in text
    assert client.closed_by_peer()
    other = _client(endpoint)  # the server lives on
    other.expect(is_cmd(Handshake))


def test_garbage_stream_never_kills_server(endpoint: EndpointThread) -> None:
    import random

    rng = random.Random(7)
    for _ in range(20):
        c = _client(endpoint)
        c.send(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 400))))
        c.close()
    ok = _client(endpoint)
    ok.send(TopicListRequest().encode())
    ok.expect(is_cmd(TopicListReply))


def test_keepalives_sent_to_idle_clients(client: RawClient) -> None:
    client.expect(lambda e: isinstance(e, KeepaliveReceived), timeout=2)


def test_idle_client_is_closed() -> None:
    options = EndpointOptions(port=0, keepalive_interval=0.1, idle_timeout=0.5)
    with EndpointThread(options) as ep:
        c = RawClient(ep.port)
        assert c.closed_by_peer(timeout=3)


def test_slow_client_drops_oldest_and_is_told(endpoint: EndpointThread) -> None:
    options = EndpointOptions(port=0, write_high_water=64 * 1024, warn_interval=0.0)
    with EndpointThread(options) as ep:
        slow = RawClient(ep.port)
        slow.send(
            encode_frame(
                "__subscribe",
                json.dumps(
                    {"topic": "/img", "message_name": "std_msgs/String", "queue_size": 5}
                ).encode(),
            )
        )
        slow.send(TopicListRequest().encode())
        slow.expect(is_cmd(TopicListReply))
        pub = RawClient(ep.port)
        pub.send(Publish("/img", "std_msgs/String", queue_size=5).encode())
        blob = struct.pack("<I", 100_000) + b"x" * 100_000
        for _ in range(200):
            pub.send(encode_frame("/img", blob))
        pub.send(StatsRequest().encode())
        pub.expect(is_cmd(StatsReply))
        stats = ep.call(ep.server.stats)
        assert stats["dropped_total"] > 0
        # The slow client eventually reads: it gets a warning and at most the queued tail.
        warn = slow.expect(is_cmd(WarnMessage), timeout=10)
        assert "dropped" in warn.command.text
        slow.close()
        pub.close()


def test_stats_command(client: RawClient) -> None:
    stats = client.stats()
    assert stats["server"]["clients"] >= 1
    assert "dropped" in stats["session"]


def test_twenty_concurrent_clients(endpoint: EndpointThread) -> None:
    clients = [_client(endpoint) for _ in range(20)]
    for c in clients:
        c.send(Subscribe("/chatter", "std_msgs/String").encode())
        c.send(TopicListRequest().encode())
        c.expect(is_cmd(TopicListReply))
    for i, c in enumerate(clients):
        c.send(Publish("/chatter", "std_msgs/String").encode())
        c.send(encode_frame("/chatter", struct.pack("<I", 1) + bytes([65 + i])))
    for c in clients:
        got: set[bytes] = set()
        while len(got) < 20:
            got.add(c.expect(lambda e: isinstance(e, MessageReceived)).payload)
        assert len(got) == 20
    for c in clients:
        c.close()


def test_subscriber_counts_reported_when_asked(endpoint: EndpointThread) -> None:
    from simbridge.protocol import SubscriberCount

    pub = _client(endpoint)
    handshake = pub.expect(is_cmd(Handshake)).command
    assert "subscribers" in handshake.metadata["extensions"]
    pub.send(Publish("/scan", "sensor_msgs/LaserScan", report_subscribers=True).encode())
    assert pub.expect(is_cmd(SubscriberCount)).command == SubscriberCount("/scan", 0)
    sub = _client(endpoint)
    sub.send(Subscribe("/scan", "sensor_msgs/LaserScan").encode())
    assert pub.expect(is_cmd(SubscriberCount)).command == SubscriberCount("/scan", 1)
    sub.close()  # disconnecting drops the subscription
    assert pub.expect(is_cmd(SubscriberCount)).command == SubscriberCount("/scan", 0)
    # A publisher that did not ask gets no counts.
    quiet = _client(endpoint)
    quiet.send(Publish("/other", "std_msgs/String").encode())
    sub2 = _client(endpoint)
    sub2.send(Subscribe("/other", "std_msgs/String").encode())
    sync(sub2)
    quiet.poll(0.3)
    assert not [
        e
        for e in quiet.events
        if isinstance(e, CommandReceived) and isinstance(e.command, SubscriberCount)
    ]


def test_registrations_per_client_are_bounded() -> None:
    with EndpointThread(EndpointOptions(port=0, max_registrations=3)) as ep:
        c = RawClient(ep.port)
        for i in range(3):
            c.send(Publish(f"/t{i}", "std_msgs/String").encode())
        c.send(Subscribe("/one_too_many", "std_msgs/String").encode())
        text = error_text(c)
        assert "'/one_too_many'" in text
        assert "3 registrations" in text
        c.send(Publish("/t0", "std_msgs/String").encode())  # re-registering is fine
        c.send(RemovePublisher("/t1").encode())
        c.send(Subscribe("/now_fits", "std_msgs/String").encode())
        sync(c)
        assert not [e for e in c.events if is_cmd(ErrorMessage)(e)]
        c.close()


def test_inflight_service_calls_per_client_are_bounded() -> None:
    with EndpointThread(EndpointOptions(port=0, max_inflight_calls=2, service_timeout=5)) as ep:
        server, caller = RawClient(ep.port), RawClient(ep.port)
        server.send(UnityService("/slow", "std_srvs/Empty").encode())
        sync(server)
        caller.send(RosService("/slow", "std_srvs/Empty").encode())
        for srv_id in (1, 2, 3):
            caller.send(ProtocolConnection.service_request(srv_id, "/slow", b""))
        refused = caller.expect(is_cmd(ErrorMessage)).command
        assert refused.srv_id == 3
        assert "2 calls already in flight" in refused.text
        # The two accepted calls reached the provider and are answered normally.
        for _ in range(2):
            req = server.expect(lambda e: isinstance(e, ServiceRequestReceived))
            server.send(ProtocolConnection.service_response(req.srv_id, "/slow", b""))
        got = {
            caller.expect(lambda e: isinstance(e, ServiceResponseReceived)).srv_id for _ in range(2)
        }
        assert got == {1, 2}


def test_flood_of_unregistered_topics_stays_bounded(
    client: RawClient, endpoint: EndpointThread
) -> None:
    client.send(b"".join(encode_frame(f"/junk{i}", b"x") for i in range(5000)))
    sync(client)
    sessions = endpoint.call(lambda: list(endpoint.server.sessions))
    assert all(len(s.unregistered) <= 1024 for s in sessions)


def test_connections_are_bounded() -> None:
    with EndpointThread(EndpointOptions(port=0, max_clients=2)) as ep:
        a, b = RawClient(ep.port), RawClient(ep.port)
        sync(a)
        sync(b)
        third = RawClient(ep.port)
        assert "endpoint full" in error_text(third)
        assert third.closed_by_peer()
        a.close()
        assert ep.call(lambda: len(ep.server.sessions)) <= 2
        deadline = time.monotonic() + 5
        while ep.call(lambda: len(ep.server.sessions)) > 1 and time.monotonic() < deadline:
            time.sleep(0.02)
        sync(RawClient(ep.port))  # room again
