"""`simbridge topic|service` against a ROS 2 endpoint: YAML in ROS 2 field names.

The endpoint is the local bus in ROS 2 mode (CDR, ROS 2 layouts); the tools learn the
protocol from its handshake. The other side is an in-process ROS 2 bus node.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from simbridge.cli import main
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.messages import ros2_registry

REG2 = ros2_registry()


@pytest.fixture
def node() -> Iterator[tuple[str, Node]]:
    with EndpointThread(EndpointOptions(port=0), LocalBus("ROS2")) as endpoint:
        bus = endpoint.backend
        assert isinstance(bus, LocalBus)
        with Node(bus, "/ros2_side") as ros2_node:
            yield f"127.0.0.1:{endpoint.port}", ros2_node


def test_pub_with_ros2_field_names(node: tuple[str, Node]) -> None:
    address, ros2 = node
    got: queue.Queue[Any] = queue.Queue()
    ros2.subscribe("/camera_info", "sensor_msgs/msg/CameraInfo", got.put)
    data = "{header: {stamp: {sec: 1, nanosec: 2}, frame_id: cam}, k: [1, 0, 2, 0, 1, 3, 0, 0, 1]}"
    args = ["topic", "pub", "/camera_info", "sensor_msgs/CameraInfo", data, "-l"]
    assert main([*args, "--linger", "0.2", "--endpoint", address]) == 0
    info = got.get(timeout=5)
    assert info.k.tolist() == [1, 0, 2, 0, 1, 3, 0, 0, 1]
    assert (info.header.stamp.sec, info.header.stamp.nanosec) == (1, 2)


def test_echo_prints_ros2_field_names(
    node: tuple[str, Node], capsys: pytest.CaptureFixture[str]
) -> None:
    address, ros2 = node
    pub = ros2.advertise("/pose", "geometry_msgs/PoseStamped")
    msg = REG2.new("geometry_msgs/PoseStamped", header={"stamp": {"sec": 4, "nanosec": 5}})
    result: list[int] = []
    args = ["topic", "echo", "/pose", "-n", "1", "--duration", "10", "--endpoint", address]
    echo = threading.Thread(target=lambda: result.append(main(args)))
    echo.start()
    for _ in range(100):
        pub.publish(msg)
        echo.join(0.1)
        if not echo.is_alive():
            break
    assert result == [0]
    out = capsys.readouterr().out
    assert "stamp: {sec: 4, nanosec: 5}" in out
    assert "seq" not in out


def test_list_hz_and_service_call(
    node: tuple[str, Node], capsys: pytest.CaptureFixture[str]
) -> None:
    address, ros2 = node
    ros2.serve(
        "/enable",
        "std_srvs/srv/SetBool",
        lambda req: REG2.new("std_srvs/SetBoolResponse", success=req.data, message="enabled"),
    )
    call = ["service", "call", "/enable", "std_srvs/srv/SetBool", "{data: true}"]
    assert main([*call, "--endpoint", address]) == 0
    out = capsys.readouterr().out
    assert "success: true" in out
    assert "message: enabled" in out

    pub = ros2.advertise("/clock", "rosgraph_msgs/Clock")
    assert main(["topic", "list", "-v", "--endpoint", address]) == 0
    assert "/clock  rosgraph_msgs/Clock" in capsys.readouterr().out

    stop = threading.Event()

    def tick() -> None:
        while not stop.wait(0.02):
            pub.publish(REG2.new("rosgraph_msgs/Clock"))

    ticker = threading.Thread(target=tick)
    ticker.start()
    try:
        start = time.monotonic()
        assert main(["topic", "hz", "/clock", "--duration", "2.5", "--endpoint", address]) == 0
        assert time.monotonic() - start < 60  # it ends after its duration, not never
    finally:
        stop.set()
        ticker.join()
    rates = [float(line.split()[2]) for line in capsys.readouterr().out.splitlines()]
    assert rates
    assert 20 < rates[-1] < 60  # published every 20 ms


def test_endpoint_command_plays_a_ros2_graph() -> None:
    """`simbridge endpoint --protocol ros2`: the local bus, announced as ROS2 in the handshake."""
    import re
    import subprocess
    import sys

    from simbridge.connector import Connector

    proc = subprocess.Popen(
        [sys.executable, "-m", "simbridge.cli", "endpoint", "--protocol", "ros2", "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        assert proc.stdout is not None
        match = None
        for line in proc.stdout:
            match = re.search(r"listening on 127\.0\.0\.1:(\d+) \(backend local\)", line)
            if match:
                break
        assert match
        with Connector("127.0.0.1", int(match.group(1))).connect() as conn:
            assert conn.handshake is not None
            assert conn.handshake.protocol == "ROS2"
            assert conn.registry is REG2
    finally:
        proc.terminate()
        proc.wait(10)
