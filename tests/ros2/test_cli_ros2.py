"""`simbridge topic|service` through `simbridge endpoint --backend ros2` to rclpy nodes:
a user without the `ros2` CLI still has one, with YAML in ROS 2 field names."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from simbridge.cli import main
from tests.ros2support import Ros2Process, start_endpoint, until_discovered

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(240)]


@pytest.fixture(scope="module")
def address() -> Iterator[str]:
    proc, port = start_endpoint("--idle-timeout", "0")
    try:
        yield f"127.0.0.1:{port}"
    finally:
        proc.stop()


def test_echo_and_list_see_an_rclpy_publisher(
    address: str, capsys: pytest.CaptureFixture[str]
) -> None:
    values = '{"header": {"stamp": {"sec": 7, "nanosec": 8}, "frame_id": "map"}}'
    with Ros2Process.node("pub", "/goal", "geometry_msgs/msg/PoseStamped", values, "10", "300"):
        args = ["topic", "echo", "/goal", "-n", "1", "--duration", "60", "--endpoint", address]
        listing = ""
        deadline = time.monotonic() + 30
        while "/goal" not in listing and time.monotonic() < deadline:
            time.sleep(0.2)  # until the endpoint's node has discovered the publisher
            assert main(["topic", "list", "-v", "--endpoint", address]) == 0
            listing = capsys.readouterr().out
        assert "geometry_msgs/PoseStamped" in listing
        assert main(args) == 0
    out = capsys.readouterr().out
    assert "stamp: {sec: 7, nanosec: 8}" in out
    assert "frame_id: map" in out
    assert "seq" not in out


def test_pub_reaches_an_rclpy_subscriber(address: str) -> None:
    with Ros2Process.node("echo", "/stamped", "geometry_msgs/msg/PoseStamped", "1") as echo:
        assert echo.expect_json("ready", timeout=60) is True
        data = "{header: {stamp: {sec: 3, nanosec: 4}, frame_id: base}, pose: {position: {x: 1.5}}}"
        args = ["topic", "pub", "/stamped", "geometry_msgs/PoseStamped", data, "-r", "5"]
        assert main([*args, "-n", "30", "--endpoint", address]) == 0
        msg = echo.expect_json("msg", timeout=30)
    assert msg["header"] == {"stamp": {"sec": 3, "nanosec": 4}, "frame_id": "base"}
    assert msg["pose"]["position"]["x"] == 1.5


def test_service_call_reaches_an_rclpy_server(
    address: str, capsys: pytest.CaptureFixture[str]
) -> None:
    answer = '{"success": true, "message": "armed"}'
    with Ros2Process.node("serve", "/arm", "std_srvs/srv/SetBool", answer) as server:
        assert server.expect_json("ready", timeout=60) is True
        call = [
            "service",
            "call",
            "/arm",
            "std_srvs/srv/SetBool",
            "{data: true}",
            "--timeout",
            "20",
        ]

        def call_once() -> None:
            if main([*call, "--endpoint", address]) != 0:
                raise AssertionError(capsys.readouterr().err)

        until_discovered(call_once)
        assert server.expect_json("request", timeout=30) == {"data": True}
    out = capsys.readouterr().out
    assert "success: true" in out
    assert "message: armed" in out
