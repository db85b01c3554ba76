"""A Connector that dials an endpoint in its own process (`dial=`, EndpointThread.dial): no
port, one end of a socketpair per connection, and everything else as over TCP (what the
sim's own ROS 2 node is built on, `simbridge.apps.ros2_node`)."""

from __future__ import annotations

import threading
import time

import pytest

from simbridge.connector import Connector
from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.endpoint.backends.local import LocalBus
from simbridge.endpoint.inprocess import Node
from simbridge.messages import registry_for

WAIT = 60.0


def test_a_dialed_connection_publishes_subscribes_and_serves_without_a_port() -> None:
    bus = LocalBus("ROS2")
    reg = registry_for("ROS2")
    with EndpointThread(EndpointOptions(port=0), bus, listen=False) as endpoint:
        assert endpoint.port == 0  # nothing listens
        with (
            Connector("in-process", 0, dial=endpoint.dial).connect(wait=WAIT) as sim,
            Node(bus, "ros_side") as ros,
        ):
            assert sim.protocol == "ROS2"  # from the handshake over the socketpair
            got: list[float] = []
            arrived = threading.Event()

            def on_cmd(msg: object) -> None:
                got.append(msg.linear.x)  # type: ignore[attr-defined]
                arrived.set()

            sim.subscribe("/cmd_vel", "geometry_msgs/Twist", on_cmd)
            sim.implement_service(
                "/reset",
                "std_srvs/Trigger",
                lambda _req: reg.new("std_srvs/TriggerResponse", success=True, message="done"),
            )
            heard = threading.Event()
            stamps: list[int] = []

            def on_clock(msg: object) -> None:
                stamps.append(msg.clock.sec)  # type: ignore[attr-defined]
                heard.set()

            ros.subscribe("/clock", "rosgraph_msgs/Clock", on_clock)
            clock = sim.register_publisher("/clock", "rosgraph_msgs/Clock")
            cmd = ros.advertise("/cmd_vel", "geometry_msgs/Twist")
            deadline = time.monotonic() + WAIT
            while not (heard.is_set() and arrived.is_set()) and time.monotonic() < deadline:
                # again until both arrive: the first may go out before the other side's
                # registration is in place
                clock.publish(reg.new("rosgraph_msgs/Clock", clock={"sec": 7}))
                cmd.publish(reg.new("geometry_msgs/Twist", linear={"x": 0.5}))
                time.sleep(0.05)
            assert heard.is_set(), "the Connector's /clock never reached the bus"
            assert arrived.is_set(), "the bus's /cmd_vel never reached the Connector"
            answer = ros.call("/reset", "std_srvs/Trigger", reg.new("std_srvs/TriggerRequest"))
        assert (answer.success, answer.message) == (True, "done")
        assert set(stamps) == {7}
        assert set(got) == {0.5}


def test_dialing_a_stopped_endpoint_is_refused_as_tcp_would_be() -> None:
    """An OSError the Connector's reconnection handles (ConnectionRefusedError), not a
    crash of its I/O thread."""
    endpoint = EndpointThread(EndpointOptions(port=0), LocalBus("ROS2"), listen=False).start()
    endpoint.stop()
    with pytest.raises(ConnectionRefusedError, match="not running"):
        endpoint.dial()
