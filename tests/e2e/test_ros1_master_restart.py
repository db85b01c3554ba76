"""A ROS master killed with SIGKILL and started again on the same port: simbridge's nodes
(an endpoint serving two clients, the planner) register everything again within seconds."""

from __future__ import annotations

import dataclasses
import re
import sys
import time

import pytest
from tests.ros1support import FAST as E2E_FAST
from tests.ros1support import (
    RosMaster,
    require_ros,
    ros_string,
    terminate,
    wait_until,
)

from simbridge.connector import Connector

require_ros(module_level=True)

import rosgraph  # noqa: E402

from simbridge.endpoint.backends.ros1 import probe_service  # noqa: E402
from simbridge.errors import EndpointError  # noqa: E402

pytestmark = [pytest.mark.ros1, pytest.mark.timeout(240)]

FAST = dataclasses.replace(E2E_FAST, dead_timeout=2.0)
LISTENING = re.compile(r"listening on \S+:(\d+)")


def registered(master: RosMaster, entry: str) -> bool:
    """Whether `kind:name` (pub, sub or srv) has a provider in the master."""
    kind, name = entry.split(":", 1)
    try:
        state = rosgraph.Master("/restart_test", master_uri=master.uri).getSystemState()
    except OSError:
        return False
    index = ("pub", "sub", "srv").index(kind)
    return any(topic == name and nodes for topic, nodes in state[index])


def planner_answers(master: RosMaster, node: str) -> bool:
    try:
        return probe_service(master.uri, "/niryo_moveit") == node
    except EndpointError:
        return False


def test_kill_9_master_restart_registers_everything_again() -> None:
    require_ros()
    master = RosMaster().start()
    command = [sys.executable, "-m", "simbridge.cli"]
    options = ["--port", "0", "--idle-timeout", "0"]  # the OS picks it as the endpoint binds
    endpoint = master.spawn(
        [*command, "endpoint", "--backend", "ros1", "--node-name", "/restart_endpoint", *options]
    )
    wait_until(lambda: LISTENING.search(endpoint.output()[0]) is not None, 60, "the endpoint")
    match = LISTENING.search(endpoint.output()[0])
    assert match is not None
    endpoint_port = int(match[1])
    planner = master.spawn([*command, "planner", "--node-name", "restart_planner"])
    sim = Connector("127.0.0.1", endpoint_port, FAST)
    tool = Connector("127.0.0.1", endpoint_port, FAST)
    try:
        sim.connect(wait=30)
        tool.connect(wait=10)
        publisher = sim.register_publisher("/rs/state", "std_msgs/String")
        sim.implement_service(
            "/rs/toggle", "std_srvs/SetBool", lambda _: b"\x01" + ros_string("sim on"), raw=True
        )
        received: list[bytes] = []
        tool.subscribe("/rs/cmd", "std_msgs/String", received.append, raw=True)
        entries = ["pub:/rs/state", "srv:/rs/toggle", "sub:/rs/cmd", "srv:/niryo_moveit"]
        wait_until(lambda: all(registered(master, e) for e in entries), 60, "the registrations")
        wait_until(lambda: planner_answers(master, "/restart_planner"), 60, "the planner")

        master.kill()
        assert not registered(master, "pub:/rs/state")
        restarting = time.monotonic()
        master.start()  # same port, empty state; returns once /rosout_agg is up
        boot = time.monotonic() - restarting
        # how soon is the endpoint's master watch (a figure, printed); that it happens is the test
        took = wait_until(
            lambda: all(registered(master, e) for e in entries),
            60,
            "every registration of both clients and the planner",
        )
        print(f"roscore boot {boot:.2f} s; everything registered again {took:.2f} s after")

        # rostopic echo sees the sim's topic again
        with master.running(["rostopic", "echo", "-n", "1", "/rs/state"]) as echo:
            deadline = time.monotonic() + 30
            while echo.poll() is None and time.monotonic() < deadline:
                publisher.publish(ros_string("after restart"))
                time.sleep(0.1)
            out, err = echo.communicate(timeout=5)
        assert echo.returncode == 0, err
        assert out.splitlines()[0] == 'data: "after restart"'
        # rosservice call reaches the sim's service
        call = master.run(["rosservice", "call", "/rs/toggle", "data: true"])
        assert call.returncode == 0, call.stderr
        assert call.stdout.split() == ["success:", "True", "message:", '"sim', 'on"']
        # a new ROS publisher on an old topic reaches the client
        pub = ["rostopic", "pub", "-r", "10", "/rs/cmd", "std_msgs/String", "data: new"]
        with master.running(pub):
            wait_until(lambda: ros_string("new") in received, 30, "the new publisher's message")
        # the planner serves again
        assert planner_answers(master, "/restart_planner")
        assert sim.connected
        assert tool.connected
    finally:
        sim.close()
        tool.close()
        terminate(endpoint)
        terminate(planner)
        master.stop()
