"""In-process nodes on the local bus, alone and talking to TCP clients."""

from __future__ import annotations

import queue
from collections.abc import Iterator
from typing import Any

import pytest
from tests.endpoint.rawclient import RawClient
from tests.endpoint.test_server import sync

from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.errors import EndpointError, ServiceError
from simbridge.messages import default_registry
from simbridge.protocol import (
    MessageReceived,
    ProtocolConnection,
    RosService,
    ServiceResponseReceived,
    Subscribe,
)

REG = default_registry()


@pytest.fixture
def endpoint() -> Iterator[EndpointThread]:
    with EndpointThread(EndpointOptions(port=0)) as ep:
        yield ep


def node(ep: EndpointThread, name: str) -> Node:
    assert isinstance(ep.backend, LocalBus)
    return Node(ep.backend, name)


def test_publish_subscribe_between_nodes(endpoint: EndpointThread) -> None:
    got: queue.Queue[Any] = queue.Queue()
    with node(endpoint, "/listener") as listener, node(endpoint, "/talker") as talker:
        listener.subscribe("/cmd_vel", "geometry_msgs/Twist", got.put)
        pub = talker.advertise("/cmd_vel", "geometry_msgs/Twist")
        msg = REG.new("geometry_msgs/Twist")
        msg.linear.x = 0.5
        pub.publish(msg)
        received = got.get(timeout=5)
    assert received.linear.x == 0.5
    assert received.angular.z == 0.0


def test_service_served_by_node_called_by_tcp_client(endpoint: EndpointThread) -> None:
    def handle(req: Any) -> Any:
        return REG.new("std_srvs/SetBoolResponse", success=req.data, message="flipped")

    with node(endpoint, "/server") as server:
        server.serve("/flip", "std_srvs/SetBool", handle)
        client = RawClient(endpoint.port)
        client.send(RosService("/flip", "std_srvs/SetBool").encode())
        request = REG.encode(REG.new("std_srvs/SetBoolRequest", data=True))
        client.send(ProtocolConnection.service_request(1, "/flip", request))
        event = client.expect(lambda e: isinstance(e, ServiceResponseReceived))
        response = REG.decode(event.payload, "std_srvs/SetBoolResponse")
        assert response.success is True
        assert response.message == "flipped"
        client.close()


def test_node_publishes_to_tcp_subscriber(endpoint: EndpointThread) -> None:
    client = RawClient(endpoint.port)
    client.send(Subscribe("/chatter", "std_msgs/String").encode())
    sync(client)
    with node(endpoint, "/talker") as talker:
        talker.advertise("/chatter", "std_msgs/String").publish(
            REG.new("std_msgs/String", data="hi")
        )
        event = client.expect(lambda e: isinstance(e, MessageReceived))
    assert REG.decode(event.payload, "std_msgs/String").data == "hi"
    client.close()


def test_node_call_between_nodes_and_missing_service(endpoint: EndpointThread) -> None:
    with node(endpoint, "/a") as a, node(endpoint, "/b") as b:
        a.serve(
            "/trigger",
            "std_srvs/Trigger",
            lambda req: REG.new("std_srvs/TriggerResponse", success=True),
        )
        assert b.call("/trigger", "std_srvs/Trigger", REG.new("std_srvs/TriggerRequest")).success
        with pytest.raises(ServiceError, match="no provider"):
            b.call("/absent", "std_srvs/Trigger", REG.new("std_srvs/TriggerRequest"), timeout=1)


def test_failing_handler_gives_caller_an_error(endpoint: EndpointThread) -> None:
    def broken(req: Any) -> Any:
        raise ValueError("planner exploded")

    with node(endpoint, "/a") as a, node(endpoint, "/b") as b:
        a.serve("/broken", "std_srvs/Trigger", broken)
        with pytest.raises(ServiceError, match="planner exploded"):
            b.call("/broken", "std_srvs/Trigger", REG.new("std_srvs/TriggerRequest"))


def test_slow_callback_keeps_the_newest_queue_size_messages(endpoint: EndpointThread) -> None:
    """A callback that falls behind holds at most queue_size messages: the oldest are
    dropped and counted, the newest kept in order (as a ROS subscriber queue)."""
    import threading
    import time

    release, started = threading.Event(), threading.Event()
    got: list[int] = []

    def slow(msg: Any) -> None:
        started.set()
        release.wait(10)
        got.append(msg.data)

    sent = 500
    with node(endpoint, "/slow") as listener, node(endpoint, "/fast") as talker:
        listener.subscribe("/counter", "std_msgs/Int32", slow, queue_size=10)
        pub = talker.advertise("/counter", "std_msgs/Int32")
        pub.publish(REG.new("std_msgs/Int32", data=0))
        assert started.wait(5)  # the callback now blocks on message 0
        for i in range(1, sent):
            pub.publish(REG.new("std_msgs/Int32", data=i))
        deadline = time.monotonic() + 10
        while listener.dropped.get("/counter", 0) < sent - 11 and time.monotonic() < deadline:
            time.sleep(0.01)
        release.set()
        while len(got) < 11 and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.1)
        assert got == [0, *range(sent - 10, sent)]
        assert listener.dropped == {"/counter": sent - 11}


def test_queue_size_must_be_positive(endpoint: EndpointThread) -> None:
    with node(endpoint, "/n") as listener, pytest.raises(EndpointError, match="queue_size 0"):
        listener.subscribe("/x", "std_msgs/Int32", lambda _msg: None, queue_size=0)
