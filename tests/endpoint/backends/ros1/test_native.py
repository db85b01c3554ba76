"""The ROS 1 backend's native TCPROS data path against a real roscore and real rospy:
header checks, drops past queue_size (counted), TCP back-pressure towards a ROS
publisher while the consumer is blocked, reconnecting to a publisher the master still
lists, and the rospy transport still selectable."""

from __future__ import annotations

import asyncio
import json
import select
import socket
import struct
import threading
import time
import xmlrpc.client
from typing import Any

import pytest
from tests.endpoint.rawclient import RawClient
from tests.endpoint.tcpros_publisher import Plan, RawPublisher
from tests.ros1support import RosMaster, require_ros, ros_string, until, with_backend

from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.endpoint.session.pushback import PUSHBACK_LIMIT
from simbridge.protocol import (
    CommandReceived,
    MessageReceived,
    Publish,
    TopicListReply,
    TopicListRequest,
    encode_frame,
)
from simbridge.protocol.tcpros import TcprosDecoder, encode_header

require_ros(module_level=True)

import rospy  # noqa: E402

from simbridge.endpoint.backends.ros1 import (  # noqa: E402
    Ros1Backend,
    Ros1Options,
    Ros1Publisher,
    Ros1Types,
    raw_message_class,
)
from simbridge.endpoint.backends.ros1.tcpros_sub import (  # noqa: E402
    RETRY_FIRST,
    RETRY_MAX,
    SubscribedTopic,
)
from simbridge.messages import default_registry  # noqa: E402

pytestmark = [
    pytest.mark.ros1,
    pytest.mark.timeout(120),
    pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning"),
    pytest.mark.filterwarnings("ignore:The publisher should be created:SyntaxWarning"),
]

STRING = Ros1Types(default_registry()).message("std_msgs/String")


def tcpros_address(topic: str) -> tuple[str, int]:
    """Ask this process's node, over its real XML-RPC slave API, where `topic` is served."""
    node: Any = xmlrpc.client.ServerProxy(rospy.core.get_node_uri())
    code, message, params = node.requestTopic("/sb_test", topic, [["TCPROS"]])
    assert code == 1, message
    assert params[0] == "TCPROS"
    return str(params[1]), int(params[2])


def read_header(sock: socket.socket) -> dict[str, str]:
    decoder = TcprosDecoder(1 << 20)
    while decoder.header is None:
        data = sock.recv(65536)
        assert data, "the server closed without a header"
        decoder.feed(data)
    return decoder.header


def subscriber_header(topic: str, md5sum: str = STRING.md5sum) -> bytes:
    fields = {"callerid": "/raw_sub", "topic": topic, "md5sum": md5sum, "type": STRING.name}
    return encode_header(fields)


def test_requesttopic_names_the_native_server_and_its_header_is_rospys(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> tuple[dict[str, str], int]:
        backend.advertise("/sb/native/hdr", "std_msgs/String", queue_size=1, latch=True)
        host, port = await asyncio.to_thread(tcpros_address, "/sb/native/hdr")
        assert port != rospy.impl.tcpros_base.get_tcpros_server_address()[1]
        with socket.create_connection((host, port), timeout=5) as sock:
            sock.sendall(subscriber_header("/sb/native/hdr"))
            header = await asyncio.to_thread(read_header, sock)
        return header, port

    header, _ = with_backend(scenario)
    assert header == {
        "callerid": rospy.get_caller_id(),
        "latching": "1",
        "md5sum": STRING.md5sum,
        "message_definition": STRING.definition,
        "topic": "/sb/native/hdr",
        "type": "std_msgs/String",
    }


@pytest.mark.parametrize(
    ("sent", "reason"),
    [
        (subscriber_header("/sb/native/bad", md5sum="0" * 32), "datatype/md5sum"),
        (subscriber_header("/sb/native/nobody"), "is not a publisher of"),
        (encode_header({"topic": "/sb/native/bad"}), "missing required 'md5sum'"),
        (struct.pack("<I", 5) + b"\x09\x00\x00\x00a", "bad connection header"),
    ],
)
def test_bad_subscribers_get_an_error_header_and_the_server_lives_on(
    master: RosMaster, sent: bytes, reason: str
) -> None:
    async def scenario(backend: Ros1Backend) -> tuple[dict[str, str], list[bytes]]:
        publisher = backend.advertise("/sb/native/bad", "std_msgs/String", queue_size=1, latch=True)
        publisher.publish(ros_string("still here"))
        host, port = await asyncio.to_thread(tcpros_address, "/sb/native/bad")
        with socket.create_connection((host, port), timeout=5) as sock:
            sock.sendall(sent)
            refused = await asyncio.to_thread(read_header, sock)
        assert backend.stats()["ros1_refused_connections"] >= 1
        received: list[bytes] = []
        backend.subscribe("/sb/native/bad", "std_msgs/String", received.append)
        await until(lambda: bool(received), 10, "the latched message after the bad peer")
        return refused, received

    refused, received = with_backend(scenario)
    assert reason in refused["error"]
    assert received == [ros_string("still here")]


def test_a_subscriber_that_does_not_read_loses_only_past_queue_size(master: RosMaster) -> None:
    """Drops happen only beyond the registration's queue_size, are counted, and keep the
    newest messages, in order."""
    queue_size = 5
    count = 400

    async def scenario(backend: Ros1Backend) -> tuple[list[int], int]:
        publisher = backend.advertise(
            "/sb/native/slow", "std_msgs/String", queue_size=queue_size, latch=False
        )
        assert isinstance(publisher, Ros1Publisher)
        host, port = await asyncio.to_thread(tcpros_address, "/sb/native/slow")
        sock = socket.socket()
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        sock.connect((host, port))
        sock.sendall(subscriber_header("/sb/native/slow"))
        await until(lambda: publisher.subscriber_count() == 1, 10, "the raw subscriber")
        for i in range(count):  # 64 KiB each: far more than the socket buffers hold
            publisher.publish(ros_string(f"{i:08d}" + "x" * 65536))
            await asyncio.sleep(0)
        dropped = backend.stats()["ros1_dropped_to_ros"]
        decoder = TcprosDecoder(1 << 20)
        got: list[bytes] = []
        sock.setblocking(False)
        deadline = time.monotonic() + 30
        while not got or int(got[-1][4:12]) != count - 1:
            assert time.monotonic() < deadline, f"the newest message never came; got {len(got)}"
            try:
                data = sock.recv(1 << 20)
            except BlockingIOError:
                await asyncio.sleep(0.01)  # the endpoint's loop writes what it holds
                continue
            assert data, "the endpoint closed the connection"
            got += decoder.feed(data)
        sock.close()
        publisher.close()
        return [int(m[4:12]) for m in got], dropped

    indices, dropped = with_backend(scenario)
    assert dropped > 0
    assert indices == sorted(indices)
    assert indices[-1] == count - 1  # the newest is kept
    assert len(indices) + dropped == count


def test_large_messages_reach_a_lagging_subscriber_whole_and_in_order(master: RosMaster) -> None:
    """Through the endpoint, 1 MB messages (sent from the buffers the client's frames were
    received into) to a ROS subscriber that reads slowly, and a latched one to a late
    subscriber: every byte arrives, in order, and with queue_size 0 nothing is dropped."""
    count = 12
    topic = "/sb/native/large"
    messages = [ros_string(f"{i:08d}" + chr(97 + i) * (1 << 20)) for i in range(count)]
    options = EndpointOptions(port=0, idle_timeout=0)
    with EndpointThread(options, Ros1Backend()) as ep:
        client = RawClient(ep.port)
        client.send(Publish(topic, "std_msgs/String", queue_size=0, latch=True).encode())
        client.send(TopicListRequest().encode())
        client.expect(
            lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
        )
        host, port = tcpros_address(topic)
        sock = socket.create_connection((host, port))
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 64 * 1024)
        sock.sendall(subscriber_header(topic))
        decoder = TcprosDecoder(4 << 20)
        while decoder.header is None:
            data = sock.recv(65536)
            assert data, "the server closed without a header"
            decoder.feed(data)
        sender = send_in_background(client, [encode_frame(topic, m) for m in messages])
        got: list[bytes] = []
        deadline = time.monotonic() + 60
        while len(got) < count:
            assert time.monotonic() < deadline, f"got {len(got)} of {count}"
            data = sock.recv(256 * 1024)
            assert data, "the endpoint closed the connection"
            got += decoder.feed(data)
            time.sleep(0.002)  # a slow reader: the endpoint's writes are taken in part
        sender.join(10)
        late = socket.create_connection((host, port))
        late.sendall(subscriber_header(topic))
        late_decoder = TcprosDecoder(4 << 20)
        latched: list[bytes] = []
        while not latched:
            data = late.recv(1 << 20)
            assert data, "the endpoint closed the late connection"
            latched += late_decoder.feed(data)
        stats = client.stats()
        for each in (sock, late):
            each.close()
        client.close()
    assert got == messages
    assert latched == messages[-1:]
    assert stats["server"]["backend_counters"]["ros1_dropped_to_ros"] == 0


def test_a_stalled_subscriber_pushes_back_on_the_client_then_lets_go(master: RosMaster) -> None:
    """queue_size 0 may not drop: while its ROS subscriber takes nothing, the endpoint
    stops reading the publishing client (a request sent after 40 MB of messages is not
    answered) for at most PUSHBACK_LIMIT seconds; once the subscriber reads, every
    message arrives in order and none was dropped."""
    count = 40
    topic = "/sb/native/stalled"
    messages = [ros_string(f"{i:08d}" + "s" * (1 << 20)) for i in range(count)]
    options = EndpointOptions(port=0, idle_timeout=0)
    with EndpointThread(options, Ros1Backend()) as ep:
        client = RawClient(ep.port)
        client.send(Publish(topic, "std_msgs/String", queue_size=0).encode())
        topic_list(client)
        host, port = tcpros_address(topic)
        sock = socket.socket()
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 64 * 1024)
        sock.connect((host, port))
        sock.sendall(subscriber_header(topic))
        decoder = TcprosDecoder(4 << 20)
        while decoder.header is None:  # then it reads nothing for a while
            data = sock.recv(65536)
            assert data, "the server closed without a header"
            decoder.feed(data)
        frames = [encode_frame(topic, m) for m in messages]
        started = time.monotonic()
        sender = send_in_background(client, [*frames, TopicListRequest().encode()])
        while not any(
            isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
            for e in client.events
        ):
            assert time.monotonic() - started < 60, "the topic list was never answered"
            if select.select([client.sock], [], [], 0.1)[0]:
                client.events += client.proto.receive_data(client.sock.recv(1 << 20))
        held_for = time.monotonic() - started
        got: list[bytes] = []
        deadline = time.monotonic() + 60
        while len(got) < count:
            assert time.monotonic() < deadline, f"got {len(got)} of {count}"
            data = sock.recv(1 << 20)
            assert data, "the endpoint closed the connection"
            got += decoder.feed(data)
        sender.join(10)
        stats = client.stats()
        sock.close()
        client.close()
    assert held_for >= PUSHBACK_LIMIT * 0.9  # not read meanwhile: the subscriber took nothing
    assert got == messages
    counters = stats["server"]["backend_counters"]
    assert counters["ros1_pushbacks"] >= 1
    assert counters["ros1_dropped_to_ros"] == 0


def send_in_background(client: RawClient, frames: list[bytes]) -> threading.Thread:
    """Send `frames` on a thread (the endpoint may push back on the client meanwhile); the
    socket blocks without a timeout until then (read it only when select says so)."""
    client.sock.settimeout(None)
    thread = threading.Thread(target=lambda: client.sock.sendall(b"".join(frames)), daemon=True)
    thread.start()
    return thread


def topic_list(client: RawClient) -> None:
    client.send(TopicListRequest().encode())
    client.expect(
        lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
    )


def test_blocked_consumer_pushes_back_on_a_rospy_publisher_without_loss(
    master: RosMaster,
) -> None:
    """While the consumer says it is blocked the endpoint stops reading, so rospy's
    (unqueued, synchronous) publisher waits in TCP instead of anything being dropped."""
    count = 300
    cls = raw_message_class(STRING)
    blocked = threading.Event()

    async def scenario(backend: Ros1Backend) -> tuple[list[int], int]:
        received: list[int] = []
        subscription = backend.subscribe(
            "/sb/native/bp", "std_msgs/String", lambda p: received.append(int(p[4:12]))
        )
        assert subscription.throttle(blocked.is_set)
        publisher = rospy.Publisher("/sb/native/bp", cls, queue_size=None)
        await until(lambda: publisher.get_num_connections() == 1, 10, "the connection")
        blocked.set()
        done = threading.Event()

        def publish_all() -> None:
            for i in range(count):
                publisher.publish(cls(ros_string(f"{i:08d}" + "y" * 32768)))
            done.set()

        thread = threading.Thread(target=publish_all, daemon=True)
        thread.start()
        await until(lambda: len(received) > 0, 10, "the first messages")
        await asyncio.sleep(1.0)
        while_blocked = len(received)
        assert not done.is_set(), "the publisher was never pushed back on"
        blocked.clear()  # the consumer caught up: reading resumes on its own
        await until(lambda: len(received) == count, 30, "every message")
        thread.join(10)
        publisher.unregister()
        subscription.close()
        return received, while_blocked

    received, while_blocked = with_backend(scenario)
    assert while_blocked < count
    assert received == list(range(count))


def test_replies_from_a_rospy_publisher_are_not_held_by_nagle(master: RosMaster) -> None:
    """The endpoint subscribes with tcp_nodelay 0 (rospy's default), so rospy's publisher
    keeps Nagle's algorithm on; a message sent each time the previous one arrived (a
    request/reply pattern) still goes out at once, as the endpoint acknowledges what it
    reads (held until a delayed acknowledgement, each would take 40 ms or more)."""
    count = 50
    cls = raw_message_class(STRING)
    arrived = threading.Event()

    async def scenario(backend: Ros1Backend) -> list[float]:
        subscription = backend.subscribe(
            "/sb/native/nagle", "std_msgs/String", lambda _p: arrived.set()
        )
        publisher = rospy.Publisher("/sb/native/nagle", cls, queue_size=None)
        await until(lambda: publisher.get_num_connections() == 1, 10, "the connection")
        waits: list[float] = []

        def ping_pong() -> None:
            for i in range(count):
                arrived.clear()
                start = time.monotonic()
                publisher.publish(cls(ros_string(f"{i:08d}")))
                if not arrived.wait(5):
                    return
                waits.append(time.monotonic() - start)
                time.sleep(0.001)

        await asyncio.to_thread(ping_pong)
        publisher.unregister()
        subscription.close()
        return waits

    waits = with_backend(scenario)
    assert len(waits) == count
    assert sorted(waits)[count // 2] < 0.02


def _stream_to_a_stalled_client(
    topic: str, texts: list[str]
) -> tuple[list[bytes | bytearray], dict[str, Any]]:
    """A rospy publisher streams `texts` on `topic` to a client subscribed through the
    endpoint with queue_size 4 and a small receive buffer, which does not read for the
    first 0.5 s; the payloads the client got, in order, and its session's stats."""
    cls = raw_message_class(STRING)
    options = EndpointOptions(port=0, write_high_water=64 * 1024, idle_timeout=0)
    with EndpointThread(options, Ros1Backend()) as ep:
        client = RawClient(ep.port)
        client.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 32 * 1024)
        body = {"topic": topic, "message_name": "std_msgs/String", "queue_size": 4}
        client.send(encode_frame("__subscribe", json.dumps(body).encode()))
        client.send(TopicListRequest().encode())
        client.expect(
            lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
        )
        publisher = rospy.Publisher(topic, cls, queue_size=None)
        deadline = time.monotonic() + 10
        while publisher.get_num_connections() == 0:
            assert time.monotonic() < deadline, "the endpoint never connected"
            time.sleep(0.02)
        thread = threading.Thread(
            target=lambda: [publisher.publish(cls(ros_string(text))) for text in texts],
            daemon=True,
        )
        thread.start()
        time.sleep(0.5)  # not reading: the endpoint's buffers and queue fill up
        got: list[bytes | bytearray] = []
        deadline = time.monotonic() + 60
        while len(got) < len(texts) and time.monotonic() < deadline:
            client.poll(0.1)
            got += [
                e.payload
                for e in client.events
                if isinstance(e, MessageReceived) and e.topic == topic
            ]
            client.events = [e for e in client.events if not isinstance(e, MessageReceived)]
        thread.join(10)
        stats = client.stats()
        publisher.unregister()
        client.close()
    return got, stats


def test_slow_client_is_pushed_back_on_rather_than_dropped(master: RosMaster) -> None:
    """Through the endpoint: a client that stops reading for a moment, with a small
    queue_size, still gets every message of a rospy publisher, and nothing is dropped."""
    texts = [f"{i:08d}" + "z" * 65536 for i in range(120)]
    got, stats = _stream_to_a_stalled_client("/sb/native/client", texts)
    assert [bytes(payload[4:]).decode() for payload in got] == texts
    assert stats["session"]["dropped_total"] == 0


def test_a_stream_of_small_messages_to_a_slow_client_arrives_whole(master: RosMaster) -> None:
    """Small messages of mixed sizes streamed by rospy reach the client in batches (one
    joined write per read); while the client does not read, the endpoint pushes back on
    the publisher instead of dropping past the small queue_size, and order holds."""
    texts = [f"{i:08d}" + "s" * (i % 7 * 40) for i in range(6000)]
    got, stats = _stream_to_a_stalled_client("/sb/native/small", texts)
    assert [bytes(payload[4:]).decode() for payload in got] == texts
    assert stats["session"]["dropped_total"] == 0


def test_rospy_transport_is_still_selectable(master: RosMaster) -> None:
    async def scenario(backend: Ros1Backend) -> list[bytes]:
        received: list[bytes] = []
        backend.subscribe("/sb/native/rospy", "std_msgs/String", received.append)
        publisher = backend.advertise(
            "/sb/native/rospy", "std_msgs/String", queue_size=0, latch=False
        )
        assert isinstance(publisher, Ros1Publisher)
        await until(lambda: publisher.subscriber_count() > 0, 10, "the loopback connection")
        assert backend.stats() == {}
        _, port = await asyncio.to_thread(tcpros_address, "/sb/native/rospy")
        assert port == rospy.impl.tcpros_base.get_tcpros_server_address()[1]  # rospy's own
        publisher.publish(ros_string("via rospy"))
        await until(lambda: bool(received), 10, "the message")
        return received

    assert with_backend(scenario, Ros1Options(transport="rospy")) == [ros_string("via rospy")]


def test_native_connections_show_in_getbusinfo(master: RosMaster) -> None:
    """rqt_graph and `rosnode info` read getBusInfo: the endpoint's own TCPROS connections
    are listed beside rospy's (here rospy's subscriber and publisher share the node)."""
    cls = raw_message_class(STRING)

    async def scenario(backend: Ros1Backend) -> list[list[Any]]:
        publisher = backend.advertise(
            "/sb/native/out", "std_msgs/String", queue_size=1, latch=False
        )
        assert isinstance(publisher, Ros1Publisher)
        rospy_sub = rospy.Subscriber("/sb/native/out", cls)
        rospy_pub = rospy.Publisher("/sb/native/in", cls, queue_size=1)
        backend.subscribe("/sb/native/in", "std_msgs/String", lambda _: None)
        await until(lambda: publisher.subscriber_count() == 1, 10, "rospy's subscriber")
        await until(lambda: rospy_pub.get_num_connections() == 1, 10, "the endpoint's subscriber")
        node: Any = xmlrpc.client.ServerProxy(rospy.core.get_node_uri())
        code, _, rows = await asyncio.to_thread(node.getBusInfo, "/sb_test")
        rospy_sub.unregister()
        rospy_pub.unregister()
        assert code == 1
        return [row[1:5] for row in rows if row[4].startswith("/sb/native/")]

    rows = with_backend(scenario)
    me, uri = rospy.get_caller_id(), rospy.core.get_node_uri()
    assert sorted(rows) == sorted(
        [
            [me, "o", "TCPROS", "/sb/native/out"],  # the endpoint's server -> rospy's subscriber
            [uri, "i", "TCPROS", "/sb/native/out"],  # rospy's subscriber (its own row)
            [me, "o", "TCPROS", "/sb/native/in"],  # rospy's publisher (its own row)
            [uri, "i", "TCPROS", "/sb/native/in"],  # the endpoint's subscriber connection
        ]
    )


def raw_publisher(
    master: RosMaster, topic: str, plan: list[Plan], then: Plan = "serve"
) -> RawPublisher:
    return RawPublisher(
        master.uri, topic, STRING.name, STRING.md5sum, STRING.definition, plan=plan, then=then
    )


def native_topic(backend: Ros1Backend, topic: str) -> SubscribedTopic:
    """The endpoint's subscription of `topic` (its publisher list, connections, retries)."""
    assert backend._native is not None
    return backend._native._subscribed[topic]


def between_attempts(subscribed: SubscribedTopic, uri: str) -> bool:
    """No connection to `uri` is being made: every attempt so far was accepted and closed
    by the publisher, so a later accept can only be a new attempt."""
    return uri not in subscribed.connections


def test_a_dropped_publisher_is_reconnected_while_the_master_lists_it(
    master: RosMaster,
) -> None:
    """A publisher that stays registered but drops the endpoint's connection (then fails
    the first reconnection) gets messages through again, after growing waits, counted
    as one reconnect; once it unregisters, a dropped connection is not retried."""
    topic = "/sb/native/reconnect"
    fake = raw_publisher(master, topic, ["once", "close", "serve"])

    async def scenario(backend: Ros1Backend) -> tuple[list[str], dict[str, int]]:
        received: list[str] = []
        fake.register()  # before subscribing: the registration's own publisher list
        subscription = backend.subscribe(
            topic, "std_msgs/String", lambda p: received.append(p[4:].decode())
        )
        await until(lambda: "first" in received, 20, "the first connection's message")
        await until(lambda: fake.serving() == 1, 20, "the reconnection")
        fake.publish("again")
        await until(lambda: "again" in received, 20, "a message after reconnecting")
        stats = backend.stats()
        await asyncio.to_thread(fake.unregister)
        subscribed = native_topic(backend, topic)
        await until(lambda: fake.uri not in subscribed.publishers, 20, "the master's update")
        accepted = len(fake.accepted)
        fake.drop()
        await asyncio.sleep(4 * RETRY_FIRST)
        assert len(fake.accepted) == accepted, "retried a publisher the master no longer lists"
        assert backend.stats()["ros1_reconnects"] == 1
        subscription.close()
        return received, stats

    try:
        received, stats = with_backend(scenario)
    finally:
        fake.close()
    assert received == ["first", "again"]
    assert stats["ros1_reconnects"] == 1
    assert len(fake.accepted) == 3
    # Backoff: the first retry waits RETRY_FIRST after the drop, the second twice that.
    assert fake.accepted[1] - fake.closed[0] >= RETRY_FIRST * 0.9
    assert fake.accepted[2] - fake.closed[1] >= 2 * RETRY_FIRST * 0.9


def test_reconnecting_stops_when_the_publisher_unregisters(master: RosMaster) -> None:
    """A publisher that keeps refusing the reconnections is retried while listed (found
    through publisherUpdate) and no more once the master says it left."""
    topic = "/sb/native/reconnect_gone"
    fake = raw_publisher(master, topic, ["once"], then="close")

    async def scenario(backend: Ros1Backend) -> dict[str, int]:
        received: list[str] = []
        subscription = backend.subscribe(
            topic, "std_msgs/String", lambda p: received.append(p[4:].decode())
        )
        await asyncio.to_thread(fake.register)  # after subscribing: a publisherUpdate
        await until(lambda: received == ["first"], 20, "the first connection's message")
        await until(lambda: len(fake.accepted) >= 3, 20, "two reconnection attempts")
        await asyncio.to_thread(fake.unregister)
        subscribed = native_topic(backend, topic)
        uri = fake.uri
        await until(
            lambda: uri not in subscribed.publishers and between_attempts(subscribed, uri),
            20,
            "the master's update, and no attempt under way",
        )
        accepted = len(fake.accepted)
        await asyncio.sleep(RETRY_MAX / 2 + 1)  # longer than the wait after 3 attempts
        assert len(fake.accepted) == accepted, "retried a publisher the master no longer lists"
        stats = backend.stats()
        subscription.close()
        return stats

    try:
        stats = with_backend(scenario)
    finally:
        fake.close()
    assert stats["ros1_reconnects"] == 0


def test_reconnecting_stops_when_the_subscription_ends(master: RosMaster) -> None:
    topic = "/sb/native/reconnect_unsub"
    fake = raw_publisher(master, topic, ["once"], then="close")

    async def scenario(backend: Ros1Backend) -> None:
        received: list[str] = []
        fake.register()
        subscription = backend.subscribe(
            topic, "std_msgs/String", lambda p: received.append(p[4:].decode())
        )
        subscribed = native_topic(backend, topic)
        await until(
            lambda: len(fake.accepted) >= 2 and between_attempts(subscribed, fake.uri),
            20,
            "a reconnection attempt, then the wait for the next",
        )
        subscription.close()  # with the next attempt's timer pending
        accepted = len(fake.accepted)
        await asyncio.sleep(RETRY_MAX / 2 + 1)
        assert len(fake.accepted) == accepted, "retried after the subscription ended"
        await asyncio.to_thread(fake.unregister)

    try:
        with_backend(scenario)
    finally:
        fake.close()
