"""The connector's two workers take turns reading and running callbacks (leader/follower):
the reader runs callbacks itself, yet order holds, callbacks never overlap, and a slow or
blocking callback (even one calling a service through the same connector) never stops
reading, replies or reconnection."""

from __future__ import annotations

import threading
import time
from typing import Any

from simbridge.connector import Connector
from simbridge.protocol import (
    CommandReceived,
    ProtocolConnection,
    ServiceResponseReceived,
    Subscribe,
)
from tests.connector.conftest import WORKERS
from tests.connector.fake_endpoint import FakeEndpoint


def _subscribed(ep: FakeEndpoint, count: int = 1) -> bool:
    return ep.wait_for(
        lambda: (
            sum(
                isinstance(e, CommandReceived) and isinstance(e.command, Subscribe)
                for e in ep.events()
            )
            >= count
        )
    )


def _dispatcher(conn: Connector) -> Any:
    return conn._dispatcher  # the test looks at which worker holds which role


def test_the_reader_runs_callbacks_itself(endpoint: FakeEndpoint, make_connector) -> None:
    conn = make_connector(endpoint.port).connect()
    on_reader: list[bool] = []
    conn.subscribe(
        "/in", "std_msgs/UInt8", lambda _p: on_reader.append(_dispatcher(conn).holds_io), raw=True
    )
    assert _subscribed(endpoint)
    for i in range(20):
        endpoint.send_all(ProtocolConnection.message("/in", bytes([i])))
        time.sleep(0.005)
    assert endpoint.wait_for(lambda: len(on_reader) == 20)
    # No thread hand-off: the worker that read each message ran its callback, unless it
    # was so slow (a loaded machine) that the other worker took reading over meanwhile.
    assert all(on_reader) or _dispatcher(conn).takeovers > 0


def test_order_holds_and_callbacks_never_overlap_across_takeovers(
    endpoint: FakeEndpoint, make_connector
) -> None:
    conn = make_connector(endpoint.port).connect()
    seen: list[tuple[str, int]] = []
    threads: set[str] = set()
    running = 0
    overlap = 0

    def callback(topic: str, payload: bytes) -> None:
        nonlocal running, overlap
        running += 1
        overlap = max(overlap, running)
        threads.add(threading.current_thread().name)
        n = int(payload)
        if n in (40, 120):  # stuck until the other worker has taken reading over
            assert endpoint.wait_for(lambda: not _dispatcher(conn).holds_io)
        elif n % 7 == 0:
            time.sleep(0.002)
        seen.append((topic, n))
        running -= 1

    for topic in ("/a", "/b"):
        conn.subscribe(topic, "std_msgs/String", lambda p, t=topic: callback(t, p), raw=True)
    assert _subscribed(endpoint, 2)
    sent: list[tuple[str, int]] = []
    for n in range(200):
        topic = "/a" if (n // 3) % 2 else "/b"
        sent.append((topic, n))
        endpoint.send_all(ProtocolConnection.message(topic, b"%d" % n))
        if n % 25 == 0:
            time.sleep(0.01)
    assert endpoint.wait_for(lambda: len(seen) == 200, timeout=20)
    assert seen == sent  # one queue: the order of arrival, across topics too
    assert overlap == 1
    assert threads <= WORKERS
    assert _dispatcher(conn).takeovers >= 1


def test_a_callback_calls_services_through_the_same_connector(make_connector) -> None:
    with FakeEndpoint(keepalive=0.2, service_answer=lambda _s, p: p[::-1]) as ep:
        ep.topics["/t"] = "std_msgs/UInt8"
        conn = make_connector(ep.port).connect()
        conn.register_ros_service("/rev", "std_srvs/Trigger")
        answers: list[Any] = []

        def callback(payload: bytes) -> None:
            answers.append(conn.call("/rev", payload, timeout=3.0))  # hands reading over
            # a plain future wait: the other worker takes reading over on its own
            answers.append(conn.call_service("/rev", payload + b"!").result(3.0))
            answers.append(conn.topic_list(timeout=3.0))

        conn.subscribe("/in", "std_msgs/String", callback, raw=True)
        # a sim-side service whose handler calls a ROS service in turn
        conn.implement_service(
            "/sim", "std_srvs/Trigger", lambda req: conn.call("/rev", req, timeout=3.0), raw=True
        )
        assert _subscribed(ep)
        for payload in (b"abc", b"xyz"):
            ep.send_all(ProtocolConnection.message("/in", payload))
        assert ep.wait_for(lambda: len(answers) == 6, timeout=10)
        topics = {"/t": "std_msgs/UInt8"}
        assert answers == [b"cba", b"!cba", topics, b"zyx", b"!zyx", topics]
        ep.send_all(ProtocolConnection.service_request(77, "/sim", b"hello"))
        assert ep.wait_for(lambda: ServiceResponseReceived(77, "/sim", b"olleh") in ep.events())


def test_a_blocked_callback_stalls_neither_reading_nor_replies(
    endpoint: FakeEndpoint, make_connector
) -> None:
    conn = make_connector(endpoint.port).connect()
    order: list[bytes] = []
    entered = threading.Event()
    release = threading.Event()

    def slow(payload: bytes) -> None:
        entered.set()
        release.wait(120)
        order.append(payload)

    conn.subscribe("/slow", "std_msgs/String", slow, raw=True)
    conn.subscribe("/fast", "std_msgs/String", order.append, raw=True)
    assert _subscribed(endpoint, 2)
    endpoint.send_all(ProtocolConnection.message("/slow", b"s"))
    assert entered.wait(5)
    before = conn.stats().bytes_received
    frames = [ProtocolConnection.message("/fast", b"f%d" % i) for i in range(50)]
    endpoint.send_all(b"".join(frames))
    expected = before + sum(map(len, frames))
    # read while the callback is still blocked (it waits for `release`, set only below)
    assert endpoint.wait_for(lambda: conn.stats().bytes_received >= expected, timeout=60)
    assert conn.endpoint_stats(timeout=2.0)  # a reply is read too
    assert order == []  # one callback at a time: the fast ones wait their turn
    release.set()
    assert endpoint.wait_for(lambda: len(order) == 51)
    assert order == [b"s", *(b"f%d" % i for i in range(50))]


def test_reconnects_and_reregisters_while_a_callback_blocks(make_connector) -> None:
    ep = FakeEndpoint(keepalive=0.2)
    port = ep.port
    conn = make_connector(port).connect()
    entered = threading.Event()
    release = threading.Event()
    got: list[bytes] = []

    def blocked(payload: bytes) -> None:
        entered.set()
        release.wait(10)
        got.append(payload)

    conn.subscribe("/in", "std_msgs/String", blocked, raw=True)
    assert _subscribed(ep)
    ep.send_all(ProtocolConnection.message("/in", b"1"))
    assert entered.wait(5)
    ep.stop()
    try:
        with FakeEndpoint(port=port, keepalive=0.2) as ep2:
            assert conn.wait_connected(5.0)  # the other worker reconnected
            assert _subscribed(ep2)  # and registered the subscription again
            ep2.send_all(ProtocolConnection.message("/in", b"2"))
            assert got == []  # the callback is still blocked
            release.set()
            assert ep2.wait_for(lambda: got == [b"1", b"2"])
    finally:
        release.set()
    assert conn.stats().reconnects == 1


def test_close_from_a_callback(endpoint: FakeEndpoint, make_connector) -> None:
    conn = make_connector(endpoint.port).connect()
    closed = threading.Event()

    def close(_payload: bytes) -> None:
        conn.close()
        closed.set()

    conn.subscribe("/in", "std_msgs/String", close, raw=True)
    assert _subscribed(endpoint)
    endpoint.send_all(ProtocolConnection.message("/in", b"x"))
    assert closed.wait(5)
    assert not conn.connected
    # the autouse fixture checks that both workers and the writer ended


def test_close_from_the_reader_still_tears_the_connection_down(
    endpoint: FakeEndpoint, make_connector
) -> None:
    conn = make_connector(endpoint.port).connect()
    conn.register_ros_service("/never", "std_srvs/Trigger")
    endpoint.answer = False
    pending = conn.call_service("/never", b"", timeout=30.0)
    closed = threading.Event()

    def tap(topic: str, _type: str, _payload: bytes, outgoing: bool) -> None:
        if not outgoing and not closed.is_set():
            closed.set()
            conn.close()  # on the worker holding the I/O role, in the middle of a read

    conn.add_tap(tap)
    conn.subscribe("/in", "std_msgs/String", lambda _p: None, raw=True)
    assert _subscribed(endpoint)
    endpoint.send_all(ProtocolConnection.message("/in", b"x"))
    assert closed.wait(5)
    exc = pending.exception(5)  # the teardown failed the call still in flight
    assert exc is not None
    assert "closed" in str(exc)
    assert endpoint.wait_for(lambda: not endpoint.live_conns())
