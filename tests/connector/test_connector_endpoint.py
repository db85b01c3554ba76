"""Connectors talking through a real simbridge endpoint over TCP.

Tests taking the `endpoint` fixture run once per backend: the local bus in ROS 1 mode,
the local bus in ROS 2 mode (CDR, ROS 2 layouts), and the ros2 backend, a real rclpy
node in the ROS 2 venv (`simbridge endpoint --backend ros2`, marked `ros2`). Connectors
pick the protocol from the handshake; messages come from `reg`, that protocol's registry.
Tests that also need an in-process node on the bus take `local_endpoint` instead.
"""

from __future__ import annotations

import dataclasses
import queue
import threading
import time
from collections.abc import Iterator
from typing import Any, Literal

import pytest

from simbridge.connector import Connector, ConnectorOptions
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.errors import ServiceError
from simbridge.messages import MessageRegistry, default_registry, registry_for
from tests.connector.conftest import FAST, QUICK_DEAD
from tests.waiting import wait_for

REG = default_registry()


@dataclasses.dataclass(frozen=True)
class Served:
    """An endpoint under test: its port, its protocol, and its bus when in-process."""

    port: int
    protocol: Literal["ROS1", "ROS2"]
    bus: LocalBus | None = None


@pytest.fixture(scope="module")
def ros2_endpoint_port() -> Iterator[int]:
    """One `simbridge endpoint --backend ros2` process for the module's ros2 cases."""
    from tests.ros2support import start_endpoint

    proc, port = start_endpoint("--idle-timeout", "0")
    try:
        yield port
    finally:
        proc.stop()


def _local(protocol: Literal["ROS1", "ROS2"]) -> Iterator[Served]:
    bus = LocalBus(protocol)
    with EndpointThread(EndpointOptions(port=0, keepalive_interval=0.2), bus) as ep:
        yield Served(ep.port, protocol, bus)


@pytest.fixture(params=["ROS1", "ROS2", pytest.param("ros2", marks=pytest.mark.ros2)])
def endpoint(request: pytest.FixtureRequest) -> Iterator[Served]:
    if request.param == "ros2":
        # rclpy waits up to the backend's discovery_wait (5 s) for a server to appear
        yield Served(request.getfixturevalue("ros2_endpoint_port"), "ROS2")
    else:
        yield from _local(request.param)


@pytest.fixture(params=["ROS1", "ROS2"])
def local_endpoint(request: pytest.FixtureRequest) -> Iterator[Served]:
    yield from _local(request.param)


@pytest.fixture
def reg(request: pytest.FixtureRequest) -> MessageRegistry:
    """The registry of the endpoint's protocol (what auto-mode connectors use)."""
    name = "endpoint" if "endpoint" in request.fixturenames else "local_endpoint"
    served: Served = request.getfixturevalue(name)
    return registry_for(served.protocol)


def twist(reg: MessageRegistry, x: float, z: float) -> Any:
    msg = reg.new("geometry_msgs/Twist")
    msg.linear.x = x
    msg.angular.z = z
    return msg


def test_topic_between_two_connectors_with_message_objects(endpoint, make_connector, reg):
    sim = make_connector(endpoint.port).connect()
    ros = make_connector(endpoint.port).connect()
    got: queue.Queue[Any] = queue.Queue()
    ros.subscribe("/cmd_vel", "geometry_msgs/Twist", got.put)
    assert wait_for(lambda: "/cmd_vel" in sim.topic_list())
    pub = sim.register_publisher("/cmd_vel", "geometry_msgs/Twist")
    for i in range(5):
        pub.publish(twist(reg, 0.5 * i, -0.25))
    received = [got.get(timeout=5) for _ in range(5)]
    assert [m.linear.x for m in received] == [0.0, 0.5, 1.0, 1.5, 2.0]
    assert {m.angular.z for m in received} == {-0.25}
    assert type(received[0]).__name__ == "geometry_msgs__msg__Twist"


def test_latched_topic_reaches_a_late_subscriber(endpoint, make_connector, reg):
    sim = make_connector(endpoint.port).connect()
    pub = sim.register_publisher("/map_name", "std_msgs/String", latch=True)
    pub.publish(reg.new("std_msgs/String", data="warehouse"))
    assert sim.flush(2.0)
    sim.endpoint_stats()  # a barrier: the endpoint handled the message before `late` comes
    late = make_connector(endpoint.port).connect()
    got: queue.Queue[Any] = queue.Queue()
    late.subscribe("/map_name", "std_msgs/String", got.put)
    assert got.get(timeout=5).data == "warehouse"


def test_services_both_ways(endpoint, make_connector, reg):
    server = make_connector(endpoint.port).connect()
    client = make_connector(endpoint.port).connect()

    def flip(req: Any) -> Any:
        return reg.new("std_srvs/SetBoolResponse", success=not req.data, message="flipped")

    server.implement_service("/flip", "std_srvs/SetBool", flip)
    client.register_ros_service("/flip", "std_srvs/SetBool")
    server.endpoint_stats()  # a barrier: the endpoint handled the registration before it
    response = client.call("/flip", reg.new("std_srvs/SetBoolRequest", data=True), timeout=5)
    assert (response.success, response.message) == (False, "flipped")
    raw = client.call_service(
        "/flip", reg.encode(reg.new("std_srvs/SetBoolRequest", data=False)), timeout=5
    ).result(5)
    assert reg.decode(raw, "std_srvs/SetBoolResponse").success is True


def test_services_with_an_in_process_node(local_endpoint, make_connector, reg):
    endpoint = local_endpoint
    sim = make_connector(endpoint.port).connect()
    sim.implement_service(
        "/sim/step",
        "std_srvs/Trigger",
        lambda _req: reg.new("std_srvs/TriggerResponse", success=True, message="stepped"),
    )
    assert endpoint.bus is not None
    with Node(endpoint.bus, "/ros_side") as node:
        node.serve(
            "/ros/double",
            "std_srvs/SetBool",
            lambda req: reg.new("std_srvs/SetBoolResponse", success=req.data, message="ok"),
        )
        sim.register_ros_service("/ros/double", "std_srvs/SetBool")
        answer = sim.call("/ros/double", reg.new("std_srvs/SetBoolRequest", data=True), 5.0)
        assert (answer.success, answer.message) == (True, "ok")
        sim.endpoint_stats()  # a barrier: `/sim/step` is advertised once this returns
        reply = node.call("/sim/step", "std_srvs/Trigger", reg.new("std_srvs/TriggerRequest"))
        assert (reply.success, reply.message) == (True, "stepped")


def test_call_to_a_service_nobody_serves_fails_fast(endpoint, make_connector, reg):
    sim = make_connector(endpoint.port).connect()
    sim.register_ros_service("/nobody", "std_srvs/Trigger")
    # the endpoint's answer fails it, not the call's own timeout (600 s, past the 60 s wait)
    future = sim.call_service("/nobody", reg.new("std_srvs/TriggerRequest"), 600.0)
    with pytest.raises(ServiceError, match="/nobody"):
        future.result(60.0)


def test_topic_list_names_types(endpoint, make_connector, reg):
    sim = make_connector(endpoint.port).connect()
    sim.register_publisher("/joint_states", "sensor_msgs/JointState")
    sim.subscribe("/cmd_vel", "geometry_msgs/Twist", lambda _m: None)
    assert wait_for(lambda: len(sim.topic_list()) >= 2)
    topics = sim.topic_list()
    assert topics["/joint_states"] == "sensor_msgs/JointState"
    assert topics["/cmd_vel"] == "geometry_msgs/Twist"


def test_twenty_concurrent_clients(endpoint, make_connector, reg):
    clients = [make_connector(endpoint.port).connect(wait=None) for _ in range(20)]
    assert all(c.wait_connected(5) for c in clients)
    inboxes: list[list[int]] = [[] for _ in clients]
    collected: list[int] = []
    lock = threading.Lock()
    collector = make_connector(endpoint.port).connect()

    def collect(msg: Any) -> None:
        with lock:
            collected.append(msg.data)

    collector.subscribe("/reports", "std_msgs/Int32", collect)
    reports = []
    for i, client in enumerate(clients):
        client.subscribe("/broadcast", "std_msgs/Int32", lambda m, i=i: inboxes[i].append(m.data))
        reports.append(
            client.register_publisher("/reports", "std_msgs/Int32", report_subscribers=True)
        )
    assert wait_for(lambda: len(collector.topic_list()) >= 2)
    # Every publisher sees the collector (in DDS, messages sent before a publisher and a
    # subscription have discovered each other are lost).
    assert wait_for(lambda: all((p.subscriber_count or 0) >= 1 for p in reports))
    time.sleep(0.3)  # every registration has reached the endpoint
    source = make_connector(endpoint.port).connect()
    pub = source.register_publisher("/broadcast", "std_msgs/Int32", report_subscribers=True)
    assert wait_for(lambda: (pub.subscriber_count or 0) >= 20)
    for n in range(50):
        pub.publish(reg.new("std_msgs/Int32", data=n))

    def report(i: int, n: int) -> None:
        clients[i].publish("/reports", reg.new("std_msgs/Int32", data=i * 100 + n))

    # Ten rounds of all twenty clients publishing at once. Each round waits for the one
    # before: a ROS 2 subscription keeps its newest `depth` (100) messages, so one burst
    # of all 200 may legitimately lose some; this test is about concurrency.
    for n in range(10):
        threads = [threading.Thread(target=report, args=(i, n)) for i in range(20)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        expected = 20 * (n + 1)
        assert wait_for(lambda: len(collected) == expected), len(collected)  # noqa: B023
    assert wait_for(lambda: all(len(box) == 50 for box in inboxes))
    assert all(box == list(range(50)) for box in inboxes)
    assert sorted(collected) == sorted(i * 100 + n for i in range(20) for n in range(10))


def test_traffic_resumes_after_endpoint_restart_without_reregistering():
    first = EndpointThread(EndpointOptions(port=0)).start()
    port = first.port
    options = ConnectorOptions()  # production timings: first retry after 1 s
    sim = Connector(port=port, options=options).connect()
    ros = Connector(port=port, options=options).connect()
    second: EndpointThread | None = None
    try:
        got: queue.Queue[Any] = queue.Queue()
        ros.subscribe("/odom_x", "std_msgs/Float64", lambda m: got.put(m.data))
        sim.implement_service(
            "/sim/ping",
            "std_srvs/Trigger",
            lambda _r: REG.new("std_srvs/TriggerResponse", success=True, message="pong"),
        )
        ros.register_ros_service("/sim/ping", "std_srvs/Trigger")
        pub = sim.register_publisher("/odom_x", "std_msgs/Float64")
        assert wait_for(lambda: len(ros.topic_list()) >= 1)
        pub.publish(REG.new("std_msgs/Float64", data=1.0))
        assert got.get(timeout=5) == 1.0

        first.stop()
        assert wait_for(lambda: not sim.connected and not ros.connected, timeout=3)
        t0 = time.monotonic()
        second = EndpointThread(EndpointOptions(port=port)).start()
        resumed = None
        while time.monotonic() - t0 < 60.0:
            pub.publish(REG.new("std_msgs/Float64", data=2.0))
            try:
                resumed = got.get(timeout=0.1)
                break
            except queue.Empty:
                continue
        assert resumed == 2.0, "traffic did not resume within 60 s"
        answer = ros.call("/sim/ping", REG.new("std_srvs/TriggerRequest"), timeout=30.0)
        assert answer.message == "pong"
        assert sim.stats().reconnects == 1
    finally:
        sim.close()
        ros.close()
        first.stop()
        if second is not None:
            second.stop()


def test_a_silent_endpoint_is_detected_by_the_dead_timeout(make_connector):
    with EndpointThread(EndpointOptions(port=0, keepalive_interval=0.2)) as ep:
        options = dataclasses.replace(FAST, dead_timeout=QUICK_DEAD)
        sim = make_connector(ep.port, options).connect()
        assert wait_for(lambda: sim.handshake is not None)
        assert sim.handshake is not None
        assert sim.handshake.metadata.get("keepalive") == 0.2
        # freeze the endpoint's event loop: the TCP connection stays open but goes silent
        frozen = threading.Event()
        ep.loop.call_soon_threadsafe(lambda: frozen.wait(120.0))
        assert wait_for(lambda: not sim.connected, timeout=60.0)  # while still frozen
        frozen.set()
        assert sim.wait_connected(30.0)


def test_messages_published_right_before_close_are_delivered(local_endpoint, reg):
    endpoint = local_endpoint
    got: queue.Queue[Any] = queue.Queue()
    assert endpoint.bus is not None
    with Node(endpoint.bus, "/listener") as node:
        node.subscribe("/last_words", "std_msgs/Int32", lambda m: got.put(m.data))
        with Connector(port=endpoint.port, options=FAST) as sim:
            pub = sim.register_publisher("/last_words", "std_msgs/Int32")
            for n in range(300):
                pub.publish(reg.new("std_msgs/Int32", data=n))
        received = [got.get(timeout=5) for _ in range(300)]
    assert received == list(range(300))


def test_subscriber_counts_follow_subscriptions(endpoint, make_connector, reg):
    sim = make_connector(endpoint.port).connect()
    scan = sim.register_publisher("/scan", "sensor_msgs/LaserScan", report_subscribers=True)
    plain = sim.register_publisher("/plain", "std_msgs/String")
    assert wait_for(lambda: scan.subscriber_count == 0)
    assert not scan.has_subscribers
    viewer = make_connector(endpoint.port).connect()
    sub = viewer.subscribe("/scan", "sensor_msgs/LaserScan", lambda _m: None)
    assert wait_for(lambda: scan.subscriber_count == 1)
    assert scan.has_subscribers
    sub.unsubscribe()
    assert wait_for(lambda: scan.subscriber_count == 0)
    assert plain.subscriber_count is None  # not asked for


def test_failing_sim_service_handler_fails_the_ros_call_at_once() -> None:
    """With the service_error extension the caller hears of the failure now, not at timeout."""
    import time

    from simbridge.connector import Connector, ConnectorOptions
    from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus
    from simbridge.errors import ServiceError
    from simbridge.messages import default_registry

    reg = default_registry()

    def broken(request: object) -> object:
        raise RuntimeError("gripper jammed")

    options = EndpointOptions(port=0, service_timeout=20.0)
    with EndpointThread(options) as endpoint:
        opts = ConnectorOptions(reconnect_initial=0.2)
        with (
            Connector("127.0.0.1", endpoint.port, opts).connect() as sim,
            Connector("127.0.0.1", endpoint.port, opts).connect() as tool,
        ):
            sim.implement_service("/grip", "std_srvs/Trigger", broken)
            assert sim.flush(5)
            deadline = time.monotonic() + 60
            bus = endpoint.backend
            assert isinstance(bus, LocalBus)
            while "/grip" not in endpoint.call(bus.services) and time.monotonic() < deadline:
                time.sleep(0.02)
            tool.register_ros_service("/grip", "std_srvs/Trigger")
            # the provider's error, at once: not the call's own timeout (600 s)
            future = tool.call_service("/grip", reg.new("std_srvs/TriggerRequest"), 600.0)
            with pytest.raises(ServiceError, match="gripper jammed"):
                future.result(60.0)
