"""Connector protocol behaviour against a fake endpoint built from ProtocolConnection."""

from __future__ import annotations

import dataclasses
import itertools
import logging
import struct
import threading
import time
from concurrent.futures import Future
from typing import Any

import pytest

from simbridge.connector import Connector, ConnectorOptions
from simbridge.errors import ConnectorError, ServiceError
from simbridge.protocol import (
    DEFAULT_SUBSCRIBE_QUEUE,
    CommandReceived,
    ErrorMessage,
    KeepaliveReceived,
    LogMessage,
    MessageReceived,
    ProtocolConnection,
    Publish,
    RemovePublisher,
    RemoveSubscriber,
    RemoveUnityService,
    RosService,
    ServiceResponseReceived,
    Subscribe,
    SubscriberCount,
    UnityService,
    WarnMessage,
)
from tests.connector.conftest import FAST, QUICK_DEAD, WORKERS
from tests.connector.fake_endpoint import FakeEndpoint
from tests.waiting import wait_for


def commands(events: list[Any]) -> list[Any]:
    return [e.command for e in events if isinstance(e, CommandReceived)]


def messages(events: list[Any], topic: str) -> list[bytes]:
    return [bytes(e.payload) for e in events if isinstance(e, MessageReceived) and e.topic == topic]


def test_registrations_and_messages_arrive_in_order(endpoint: FakeEndpoint, make_connector):
    conn = make_connector(endpoint.port).connect()
    pub = conn.register_publisher("/chatter", "std_msgs/String", queue_size=5, latch=True)
    conn.subscribe("/in", "std_msgs/Int32", lambda _m: None, raw=True)
    conn.register_ros_service("/add", "rospy_tutorials/AddTwoInts", raw=True)
    conn.implement_service("/sim_reset", "std_srvs/Empty", lambda _r: b"", raw=True)
    for i in range(3):
        pub.publish(bytes([i]))
    assert endpoint.wait_for(lambda: len(messages(endpoint.events(), "/chatter")) == 3)
    events = endpoint.events()
    assert isinstance(events[0], KeepaliveReceived)  # Unity sends one right after connecting
    assert commands(events) == [
        Publish("/chatter", "std_msgs/String", 5, True),
        Subscribe("/in", "std_msgs/Int32", 1000),  # the connector's default queue_size
        RosService("/add", "rospy_tutorials/AddTwoInts"),
        UnityService("/sim_reset", "std_srvs/Empty"),
    ]
    assert messages(events, "/chatter") == [b"\x00", b"\x01", b"\x02"]
    publish_at = next(i for i, e in enumerate(events) if isinstance(e, CommandReceived))
    first_msg = next(i for i, e in enumerate(events) if isinstance(e, MessageReceived))
    assert publish_at < first_msg


def test_publish_on_unregistered_topic_names_the_registered_ones(endpoint, make_connector):
    conn = make_connector(endpoint.port).connect()
    conn.register_publisher("/a", "std_msgs/String")
    with pytest.raises(ConnectorError, match=r"'/b'.*\['/a'\]"):
        conn.publish("/b", b"x")


@pytest.mark.parametrize("name", ["", "  ", "/has space", "__publish"])
def test_bad_topic_names_are_refused(name: str, make_connector):
    conn = make_connector(1)
    with pytest.raises(ConnectorError, match="topic name"):
        conn.register_publisher(name, "std_msgs/String")


def test_keepalives_when_idle(endpoint: FakeEndpoint, make_connector):
    def received() -> int:
        return sum(isinstance(e, KeepaliveReceived) for e in endpoint.events())

    start = time.monotonic()
    conn = make_connector(endpoint.port).connect()
    # one at connect, then one per 0.2 s of silence: at least 3 come (later on a busy box) ...
    assert wait_for(lambda: received() >= 3, timeout=10)
    time.sleep(0.5)
    conn.close()  # ... and never more than one per 0.2 s
    assert endpoint.wait_for(lambda: endpoint.conns[-1].closed)
    keepalives = received()
    assert keepalives <= 2 + (time.monotonic() - start) / FAST.keepalive_interval
    assert conn.stats().keepalives_sent == keepalives - 1  # closed: nothing in flight


def test_no_keepalive_while_busy(endpoint: FakeEndpoint, make_connector):
    conn = make_connector(endpoint.port).connect()
    pub = conn.register_publisher("/t", "std_msgs/String")
    end = time.monotonic() + 0.8
    sent_at: list[float] = []
    while time.monotonic() < end:
        pub.publish(b"x")
        sent_at.append(time.monotonic())
        time.sleep(0.02)
    # idle, it would have sent 4; a gap between publishes on a busy box may earn one more
    gaps = sum(b - a > FAST.keepalive_interval / 2 for a, b in itertools.pairwise(sent_at))
    assert conn.stats().keepalives_sent <= 1 + gaps


def test_silent_endpoint_is_detected_and_reconnected(make_connector):
    with FakeEndpoint(keepalive=0.2) as ep:
        conn = make_connector(ep.port, dataclasses.replace(FAST, dead_timeout=QUICK_DEAD))
        conn.connect()
        assert ep.wait_for(lambda: conn.handshake is not None)
        ep.silent = True
        assert ep.wait_for(lambda: not conn.connected, timeout=60.0)
        ep.silent = False
        assert ep.wait_conns(2)
        assert conn.wait_connected(3.0)
        assert conn.stats().reconnects == 1


def test_slow_announced_keepalive_stretches_the_dead_timeout(make_connector):
    with FakeEndpoint(keepalive=0.5) as ep:  # announces and sends one every 0.5 s
        conn = make_connector(ep.port, dataclasses.replace(FAST, dead_timeout=0.3)).connect()
        assert ep.wait_for(lambda: conn.handshake is not None)
        time.sleep(1.5)
        assert conn.connected  # 0.5 s gaps exceed 0.3 s but not two periods
        assert len(ep.conns) == 1
        ep.silent = True
        t0 = time.monotonic()
        assert ep.wait_for(lambda: not conn.connected, timeout=60.0)
        # two announced periods (1 s), not dead_timeout (0.3 s): a timer never fires early
        assert time.monotonic() - t0 >= 0.4


def test_original_endpoint_without_keepalives_is_not_dropped(make_connector):
    with FakeEndpoint(keepalive=None) as ep:
        conn = make_connector(ep.port, dataclasses.replace(FAST, dead_timeout=QUICK_DEAD))
        conn.connect()
        assert ep.wait_for(lambda: conn.handshake is not None)
        time.sleep(QUICK_DEAD * 2)
        assert conn.connected
        assert len(ep.conns) == 1


def test_reconnect_reregisters_everything_and_resends_latched(make_connector):
    ep = FakeEndpoint(keepalive=0.2, service_answer=lambda _s, p: p)
    port = ep.port
    conn = make_connector(port).connect()
    latched = conn.register_publisher("/map", "nav_msgs/OccupancyGrid", latch=True)
    plain = conn.register_publisher("/cmd", "geometry_msgs/Twist")
    conn.subscribe("/odom", "nav_msgs/Odometry", lambda _m: None, raw=True)
    conn.register_ros_service("/plan", "niryo_moveit/MoverService")
    conn.implement_service("/reset", "std_srvs/Empty", lambda _r: b"", raw=True)
    latched.publish(b"map-1")
    latched.publish(b"map-2")
    plain.publish(b"cmd-1")
    assert ep.wait_for(lambda: len(messages(ep.events(), "/cmd")) == 1)
    ep.stop()
    assert ep.wait_for(lambda: not conn.connected, timeout=2.0)
    with FakeEndpoint(port=port, keepalive=0.2, service_answer=lambda _s, p: p[::-1]) as ep2:
        assert conn.wait_connected(3.0)
        assert ep2.wait_for(lambda: len(messages(ep2.events(), "/map")) == 1)
        events = ep2.events()
        assert set(map(type, commands(events))) == {Publish, Subscribe, RosService, UnityService}
        assert messages(events, "/map") == [b"map-2"]
        assert messages(events, "/cmd") == []  # not latched: not repeated
        plain.publish(b"cmd-2")
        assert ep2.wait_for(lambda: messages(ep2.events(), "/cmd") == [b"cmd-2"])
        assert conn.call("/plan", b"abc", timeout=2.0) == b"cba"
    assert conn.stats().reconnects == 1


def test_messages_published_while_disconnected_keep_only_the_newest(make_connector):
    options = dataclasses.replace(FAST, publish_queue_size=10)
    with FakeEndpoint(keepalive=0.2) as ep:
        conn = make_connector(ep.port, options)
        pub = conn.register_publisher("/t", "std_msgs/UInt8")
        for i in range(100):
            pub.publish(bytes([i]))
        assert conn.stats().publish_drops == {"/t": 90}
        conn.connect()
        assert ep.wait_for(lambda: len(messages(ep.events(), "/t")) == 10)
        assert messages(ep.events(), "/t") == [bytes([i]) for i in range(90, 100)]
        # the registration still precedes the messages
        assert isinstance(commands(ep.events())[0], Publish)


def test_service_calls_pair_up_across_threads(make_connector):
    with FakeEndpoint(keepalive=0.2, service_answer=lambda _s, p: p + b"!") as ep:
        conn = make_connector(ep.port).connect()
        conn.register_ros_service("/echo", "std_srvs/Trigger")
        results: dict[int, bytes] = {}

        def worker(k: int) -> None:
            for j in range(20):
                request = f"{k}-{j}".encode()
                results[k * 100 + j] = conn.call("/echo", request, timeout=3.0)
                assert results[k * 100 + j] == request + b"!"

        threads = [threading.Thread(target=worker, args=(k,)) for k in range(8)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert len(results) == 160


def test_error_with_srv_id_fails_that_call_at_once(make_connector):
    with FakeEndpoint(keepalive=0.2, service_answer=lambda _s, _p: None) as ep:
        conn = make_connector(ep.port).connect()
        conn.register_ros_service("/broken", "std_srvs/Trigger")
        # at once: the call's own timeout (600 s) would outlast result()'s 60 s wait
        future = conn.call_service("/broken", b"", timeout=600.0)
        with pytest.raises(ServiceError, match="/broken failed"):
            future.result(60.0)
        assert conn.stats().errors_received == 1


def test_unanswered_call_times_out(make_connector):
    with FakeEndpoint(keepalive=0.2) as ep:
        conn = make_connector(ep.port, dataclasses.replace(FAST, service_timeout=600.0)).connect()
        conn.register_ros_service("/slow", "std_srvs/Trigger")
        t0 = time.monotonic()
        with pytest.raises(ServiceError, match="did not answer"):
            conn.call("/slow", b"", timeout=0.3)
        # its own timeout, not service_timeout (600 s); a timer never fires early
        assert 0.25 <= time.monotonic() - t0 < 60.0


def test_pending_call_fails_when_the_connection_drops(make_connector):
    ep = FakeEndpoint(keepalive=0.2)
    conn = make_connector(ep.port).connect()
    conn.register_ros_service("/slow", "std_srvs/Trigger")
    future = conn.call_service("/slow", b"", timeout=30.0)
    assert ep.wait_for(lambda: any(not isinstance(e, KeepaliveReceived) for e in ep.events()))
    time.sleep(0.1)
    ep.stop()
    with pytest.raises(ServiceError, match="connection lost"):
        future.result(2.0)


def test_call_made_while_disconnected_is_sent_on_connect(make_connector):
    with FakeEndpoint(keepalive=0.2, service_answer=lambda _s, p: p * 2) as ep:
        conn = make_connector(ep.port)
        conn.register_ros_service("/twice", "std_srvs/Trigger")
        future = conn.call_service("/twice", b"ab", timeout=3.0)
        conn.connect()
        assert future.result(3.0) == b"abab"


def test_call_on_unregistered_service_is_refused(make_connector):
    conn = make_connector(1)
    with pytest.raises(ConnectorError, match="register_ros_service"):
        conn.call_service("/nope", b"")


def test_async_call(make_connector):
    import asyncio

    with FakeEndpoint(keepalive=0.2, service_answer=lambda _s, p: p.upper()) as ep:
        conn = make_connector(ep.port).connect()
        conn.register_ros_service("/up", "std_srvs/Trigger")

        async def main() -> list[Any]:
            return await asyncio.gather(*(conn.call_async("/up", b"x%d" % i) for i in range(5)))

        assert asyncio.run(main()) == [b"X%d" % i for i in range(5)]


def test_ros_calls_a_sim_service(endpoint: FakeEndpoint, make_connector):
    conn = make_connector(endpoint.port).connect()
    seen: list[str] = []

    def handler(request: bytes) -> bytes:
        seen.append(threading.current_thread().name)
        return request[::-1]

    conn.implement_service("/sim/reverse", "std_srvs/Trigger", handler, raw=True)
    assert endpoint.wait_for(lambda: len(commands(endpoint.events())) == 1)
    endpoint.send_all(ProtocolConnection.service_request(1001, "/sim/reverse", b"hello"))
    endpoint.send_all(ProtocolConnection.service_request(1002, "/sim/reverse", b"abc"))
    assert endpoint.wait_for(
        lambda: len([e for e in endpoint.events() if isinstance(e, ServiceResponseReceived)]) == 2
    )
    responses = [e for e in endpoint.events() if isinstance(e, ServiceResponseReceived)]
    assert responses == [
        ServiceResponseReceived(1001, "/sim/reverse", b"olleh"),
        ServiceResponseReceived(1002, "/sim/reverse", b"cba"),
    ]
    assert len(seen) == 2
    assert set(seen) <= WORKERS


def test_subscription_callbacks_run_on_the_workers_and_slow_ones_do_not_stall(
    endpoint: FakeEndpoint, make_connector
):
    conn = make_connector(endpoint.port).connect()
    got: list[bytes] = []
    threads: set[str] = set()
    release = threading.Event()

    def slow(payload: bytes) -> None:
        threads.add(threading.current_thread().name)
        release.wait(30)
        got.append(payload)

    conn.subscribe("/in", "std_msgs/UInt8", slow, raw=True)
    assert endpoint.wait_for(lambda: len(commands(endpoint.events())) == 1)
    for i in range(3):
        endpoint.send_all(ProtocolConnection.message("/in", bytes([i])))
    before = sum(isinstance(e, KeepaliveReceived) for e in endpoint.events())
    # the callback blocks (until released); keepalives must continue
    assert endpoint.wait_for(
        lambda: sum(isinstance(e, KeepaliveReceived) for e in endpoint.events()) - before >= 3,
        timeout=10,
    )
    assert not got
    assert conn.connected
    endpoint.topics["/x"] = "std_msgs/UInt8"
    assert conn.topic_list(timeout=2.0) == {"/x": "std_msgs/UInt8"}  # replies are read
    release.set()
    assert endpoint.wait_for(lambda: len(got) == 3)
    assert got == [b"\x00", b"\x01", b"\x02"]
    assert threads <= WORKERS


def test_subscriber_queue_drops_oldest_and_counts(endpoint: FakeEndpoint, make_connector):
    conn = make_connector(endpoint.port).connect()
    got: list[bytes] = []
    entered, gate = threading.Event(), threading.Event()

    def blocked(payload: bytes) -> None:
        entered.set()
        gate.wait(10)
        got.append(payload)

    conn.subscribe("/in", "std_msgs/UInt8", blocked, raw=True, queue_size=3)
    assert endpoint.wait_for(lambda: len(commands(endpoint.events())) == 1)
    endpoint.send_all(ProtocolConnection.message("/in", b"\x00"))
    assert entered.wait(10)  # the first message is now inside the blocked callback
    endpoint.send_all(b"".join(ProtocolConnection.message("/in", bytes([i])) for i in range(1, 11)))
    assert endpoint.wait_for(lambda: conn.stats().subscribe_drops.get("/in") == 7)
    gate.set()
    assert endpoint.wait_for(lambda: len(got) == 4)
    assert got == [b"\x00", b"\x08", b"\x09", b"\x0a"]


def test_no_callbacks_after_unsubscribe(make_connector):
    with FakeEndpoint(keepalive=None) as ep:  # no keepalives: byte counts are exact
        conn = make_connector(ep.port).connect()
        got: list[bytes] = []
        entered = threading.Event()
        gate = threading.Event()

        def blocked(payload: bytes) -> None:
            entered.set()
            gate.wait(5)
            got.append(payload)

        sub = conn.subscribe("/in", "std_msgs/UInt8", blocked, raw=True)
        assert ep.wait_for(lambda: len(commands(ep.events())) == 1)
        before = conn.stats().bytes_received
        frames = [ProtocolConnection.message("/in", bytes([i])) for i in range(5)]
        ep.send_all(b"".join(frames))
        assert entered.wait(3)
        assert ep.wait_for(lambda: conn.stats().bytes_received == before + 5 * len(frames[0]))
        sub.unsubscribe()  # four messages are still waiting behind the blocked callback
        gate.set()
        time.sleep(0.2)
        assert got == [b"\x00"]


def test_callback_errors_are_logged_not_fatal(endpoint, make_connector, caplog):
    conn = make_connector(endpoint.port).connect()
    got: list[bytes] = []

    def flaky(payload: bytes) -> None:
        if payload == b"bad":
            raise ValueError("boom")
        got.append(payload)

    conn.subscribe("/in", "std_msgs/String", flaky, raw=True)
    assert endpoint.wait_for(lambda: len(commands(endpoint.events())) == 1)
    with caplog.at_level(logging.ERROR, logger="simbridge.connector"):
        for payload in (b"ok1", b"bad", b"ok2"):
            endpoint.send_all(ProtocolConnection.message("/in", payload))
        assert endpoint.wait_for(lambda: len(got) == 2)
    assert got == [b"ok1", b"ok2"]
    assert conn.stats().callback_errors == 1
    assert "boom" in caplog.text


def test_unsubscribe_one_of_two_callbacks_then_all(endpoint: FakeEndpoint, make_connector):
    conn = make_connector(endpoint.port).connect()
    a: list[bytes] = []
    b: list[bytes] = []
    sub_a = conn.subscribe("/in", "std_msgs/String", a.append, raw=True)
    conn.subscribe("/in", "std_msgs/String", b.append, raw=True)
    with pytest.raises(ConnectorError, match="already subscribed as std_msgs/String"):
        conn.subscribe("/in", "std_msgs/Int32", a.append)
    sub_a.unsubscribe()
    endpoint.send_all(ProtocolConnection.message("/in", b"1"))
    assert endpoint.wait_for(lambda: b == [b"1"])
    assert a == []
    conn.unsubscribe("/in")
    conn.unregister_publisher("/never-registered")  # no-op, no frame
    pub = conn.register_publisher("/p", "std_msgs/String")
    conn.unregister_publisher("/p")
    with pytest.raises(ConnectorError, match="'/p' was unregistered"):
        pub.publish(b"late")
    conn.implement_service("/s", "std_srvs/Empty", lambda r: r, raw=True)
    conn.unimplement_service("/s")
    assert endpoint.wait_for(lambda: len(commands(endpoint.events())) == 6)
    assert commands(endpoint.events())[1:] == [
        RemoveSubscriber("/in"),
        Publish("/p", "std_msgs/String", 10, False),
        RemovePublisher("/p"),
        UnityService("/s", "std_srvs/Empty"),
        RemoveUnityService("/s"),
    ]


def test_endpoint_log_warn_error_go_to_logging(endpoint, make_connector, caplog):
    # no reconnect: with FAST's 0.6 s dead timeout, a loaded machine that starves the fake
    # endpoint's keepalives that long has the connector drop the connection the three
    # messages are sent on, and they are lost with it
    conn = make_connector(endpoint.port, dataclasses.replace(FAST, dead_timeout=30.0)).connect()
    assert endpoint.wait_conns(1, timeout=30)
    expected = {
        (logging.INFO, "endpoint: hello"),
        (logging.WARNING, "endpoint: dropped 3 messages"),
        (logging.ERROR, "endpoint: unknown type foo/Bar"),
    }

    def logged() -> set[tuple[int, str]]:
        return {(r.levelno, r.getMessage()) for r in list(caplog.records)}

    with caplog.at_level(logging.INFO, logger="simbridge.connector"):
        endpoint.send_all(LogMessage("hello").encode())
        endpoint.send_all(WarnMessage("dropped 3 messages").encode())
        endpoint.send_all(ErrorMessage("unknown type foo/Bar").encode())
        # the reader thread counts a message before it logs it: wait for the records
        assert endpoint.wait_for(lambda: expected <= logged(), timeout=30), logged()
    stats = conn.stats()
    assert (stats.logs_received, stats.warnings_received, stats.errors_received) == (1, 1, 1)
    assert stats.reconnects == 0


def test_topic_list_and_endpoint_stats(endpoint: FakeEndpoint, make_connector):
    endpoint.topics = {"/a": "std_msgs/String", "/b": "sensor_msgs/Image"}
    conn = make_connector(endpoint.port).connect()
    assert conn.topic_list() == {"/a": "std_msgs/String", "/b": "sensor_msgs/Image"}
    stats = conn.endpoint_stats()
    assert stats["frames_in"] >= 2


def test_stats_are_not_asked_of_an_original_endpoint(make_connector):
    with FakeEndpoint(keepalive=None) as original:
        conn = make_connector(original.port).connect()
        with pytest.raises(ConnectorError, match="does not offer __stats"):
            conn.endpoint_stats()
        assert commands(original.events()) == []


def test_original_endpoint_gets_subscribe_without_queue_size(make_connector):
    """Unity's endpoint passes the JSON fields as arguments: an extra one kills its thread."""
    with FakeEndpoint(keepalive=None) as original:
        conn = make_connector(original.port).connect()
        conn.subscribe("/in", "std_msgs/Int32", lambda _m: None, raw=True, queue_size=7)
        assert original.wait_for(lambda: commands(original.events()) != [])
        (sent,) = commands(original.events())
        assert sent == Subscribe("/in", "std_msgs/Int32", DEFAULT_SUBSCRIBE_QUEUE)
        assert sent.to_json() == {"topic": "/in", "message_name": "std_msgs/Int32"}


def test_topic_list_without_reply_times_out(endpoint: FakeEndpoint, make_connector):
    endpoint.answer = False
    conn = make_connector(endpoint.port).connect()
    with pytest.raises(ConnectorError, match=r"no reply within 0\.3 s"):
        conn.topic_list(timeout=0.3)
    endpoint.answer = True
    endpoint.topics = {"/late": "std_msgs/Empty"}
    # the late reply to the first request must not confuse the next one
    assert conn.topic_list(timeout=2.0) == {"/late": "std_msgs/Empty"}


def test_connect_timeout_raises_and_cleans_up():
    import socket

    with socket.socket() as probe:  # held bound, never listening: refused, and nobody
        probe.bind(("127.0.0.1", 0))  # else can take the port while the test runs
        port = probe.getsockname()[1]
        conn = Connector(port=port, options=FAST)
        t0 = time.monotonic()
        with pytest.raises(ConnectorError, match=f"127.0.0.1:{port} within 0.5 s"):
            conn.connect(wait=0.5)
        assert time.monotonic() - t0 < 30.0  # gave up: did not keep retrying
        assert not conn.connected


def test_close_fails_unsent_calls_and_refuses_reuse(make_connector):
    conn = make_connector(1)
    conn.register_ros_service("/x", "std_srvs/Trigger")
    future: Future[Any] = conn.call_service("/x", b"")
    conn.close()
    with pytest.raises(ServiceError, match="closed"):
        future.result(1.0)
    with pytest.raises(ConnectorError, match="closed"):
        conn.connect()


def test_close_flushes_what_was_published(endpoint: FakeEndpoint):
    with Connector(port=endpoint.port, options=FAST) as conn:
        pub = conn.register_publisher("/t", "std_msgs/String")
        for i in range(500):
            pub.publish(b"%d" % i)
    assert endpoint.wait_for(lambda: len(messages(endpoint.events(), "/t")) == 500)


def test_ros2_mode_writes_nul_terminated_names(make_connector):
    with FakeEndpoint(keepalive=0.2, protocol="ROS2") as ep:
        conn = make_connector(ep.port, dataclasses.replace(FAST, protocol="ROS2")).connect()
        conn.register_publisher("/t", "std_msgs/String").publish(b"\x00\x01\x00\x00")
        assert ep.wait_for(lambda: len(messages(ep.events(), "/t")) == 1)
        raw_topic = b"\x03\x00\x00\x00/t\x00\x04\x00\x00\x00\x00\x01\x00\x00"
        raw_publish = b"\x0a\x00\x00\x00__publish\x00"
        with ep.lock:
            conn_state = ep.conns[0]
        assert conn_state.events  # decoded fine with NULs stripped
        assert commands(conn_state.events) == [Publish("/t", "std_msgs/String", 10, False)]
        sent = conn._framer.message("/t", b"\x00\x01\x00\x00")
        assert sent == raw_topic
        assert conn._framer.command(Publish("/t", "std_msgs/String")).startswith(raw_publish)
        assert conn._framer.command(Publish("/t", "std_msgs/String")).endswith(b"}\x00")


def test_options_are_validated():
    with pytest.raises(ConnectorError, match="protocol 'ROS3'"):
        ConnectorOptions(protocol="ROS3")  # type: ignore[arg-type]
    with pytest.raises(ConnectorError, match="dead_timeout must be > 0"):
        ConnectorOptions(dead_timeout=0)
    with pytest.raises(ConnectorError, match="publish_queue_size must be >= 1"):
        ConnectorOptions(publish_queue_size=0)


def test_subscriber_counts_are_requested_only_from_endpoints_that_offer_them(make_connector):
    with FakeEndpoint(keepalive=0.2) as original:  # no "extensions" in its handshake
        conn = make_connector(original.port).connect()
        pub = conn.register_publisher("/scan", "sensor_msgs/LaserScan", report_subscribers=True)
        assert original.wait_for(lambda: len(commands(original.events())) == 1)
        assert commands(original.events()) == [Publish("/scan", "sensor_msgs/LaserScan")]
        assert pub.subscriber_count is None
        assert pub.has_subscribers  # unknown: a lazy sensor keeps publishing
    with FakeEndpoint(keepalive=0.2, extensions=["subscribers"]) as modern:
        conn = make_connector(modern.port).connect()
        pub = conn.register_publisher("/scan", "sensor_msgs/LaserScan", report_subscribers=True)
        assert modern.wait_for(lambda: len(commands(modern.events())) == 1)
        assert commands(modern.events()) == [
            Publish("/scan", "sensor_msgs/LaserScan", report_subscribers=True)
        ]
        modern.send_all(SubscriberCount("/scan", 0).encode())
        assert modern.wait_for(lambda: pub.subscriber_count == 0)
        assert not pub.has_subscribers
        modern.send_all(SubscriberCount("/scan", 2).encode())
        assert modern.wait_for(lambda: pub.subscriber_count == 2)


def test_registrations_wait_for_the_handshake_or_go_on_without(make_connector):
    with FakeEndpoint(keepalive=None, send_handshake=False) as mute:
        options = dataclasses.replace(FAST, connect_timeout=0.4)
        conn = make_connector(mute.port, options).connect(wait=None)
        conn.register_publisher("/t", "std_msgs/String")
        assert mute.wait_conns(1)
        time.sleep(0.2)
        assert not conn.connected
        assert mute.events() == []  # nothing sent before the handshake
        assert conn.wait_connected(2.0)
        assert mute.wait_for(lambda: len(commands(mute.events())) == 1)
        assert conn.handshake is None


def test_reconnect_backoff_doubles_up_to_the_maximum(monkeypatch, caplog, make_connector):
    import simbridge.connector.engine as module

    attempts: list[float] = []

    def refuse(host: str, port: int, timeout: float) -> Any:
        attempts.append(time.monotonic())
        raise ConnectionRefusedError(111, "Connection refused")

    monkeypatch.setattr(module, "open_link", refuse)
    options = dataclasses.replace(FAST, reconnect_initial=0.1, reconnect_max=0.4)
    with caplog.at_level(logging.DEBUG, logger="simbridge.connector"):
        conn = make_connector(1, options).connect(wait=None)
        assert wait_for(lambda: len(attempts) >= 6, timeout=60)
        conn.close()
    announced = [
        float(r.getMessage().rsplit("retrying in ", 1)[1].split()[0])
        for r in caplog.records
        if "retrying in" in r.getMessage()
    ][:5]
    assert announced == [0.1, 0.2, 0.4, 0.4, 0.4]
    # and each wait really lasted at least what was announced (a busy box only adds)
    gaps = [b - a for a, b in itertools.pairwise(attempts)][:5]
    for gap, expected in zip(gaps, announced, strict=True):
        assert gap >= expected - 0.02


def test_many_threads_publish_concurrently(endpoint: FakeEndpoint, make_connector):
    # no drops here; and no reconnect: FAST's 0.6 s dead timeout is not what this checks,
    # and a loaded machine can starve the keepalives that long while 8 threads publish
    options = dataclasses.replace(FAST, publish_queue_size=100_000, dead_timeout=30.0)
    conn = make_connector(endpoint.port, options).connect()
    pubs = [conn.register_publisher(f"/t{k}", "std_msgs/UInt32") for k in range(4)]

    def worker(k: int) -> None:
        for n in range(2000):
            pubs[n % 4].publish(struct.pack("<II", k, n))

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert conn.flush(60)  # generous bounds: 16,000 frames on a loaded machine
    topics = {f"/t{k}" for k in range(4)}
    assert wait_for(  # one pass per poll: the fake endpoint's reader needs the GIL too
        lambda: (
            sum(isinstance(e, MessageReceived) and e.topic in topics for e in endpoint.events())
            == 16000
        ),
        timeout=60,
    )
    assert conn.stats().reconnects == 0
    per_thread: dict[int, list[int]] = {}
    for k in range(4):
        for payload in messages(endpoint.events(), f"/t{k}"):
            thread, n = struct.unpack("<II", payload)
            per_thread.setdefault(thread, []).append(n)
    # nothing lost or duplicated, and each thread's messages on a topic keep their order
    assert {t: sorted(ns) for t, ns in per_thread.items()} == {
        t: list(range(2000)) for t in range(8)
    }
    for k in range(4):
        for thread in range(8):
            ns = [
                n
                for t, n in (struct.unpack("<II", p) for p in messages(endpoint.events(), f"/t{k}"))
                if t == thread
            ]
            assert ns == sorted(ns)
    assert conn.stats().publish_drops == {}
