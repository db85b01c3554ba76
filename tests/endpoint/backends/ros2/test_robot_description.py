"""`__set_param` on `simbridge endpoint --backend ros2`: ROS 2 has no parameter server, so
`*/robot_description` becomes a transient-local std_msgs/String topic (what
robot_state_publisher offers), which a late rclpy subscriber still receives; any other
parameter is refused with an `__error` naming it."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from tests.endpoint.rawclient import RawClient
from tests.ros2support import Ros2Process, require_ros2, start_endpoint

from simbridge.protocol import CommandReceived, ErrorMessage, Handshake, SetParam

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(240)]

URDF = '<robot name="r"><link name="base"/></robot>'


@pytest.fixture(scope="module")
def client() -> Iterator[RawClient]:
    require_ros2()
    proc, port = start_endpoint("--idle-timeout", "0")
    raw = RawClient(port)
    try:
        yield raw
    finally:
        raw.close()
        proc.stop()


def test_robot_description_is_a_latched_topic(client: RawClient) -> None:
    hello = client.expect(
        lambda e: isinstance(e, CommandReceived) and isinstance(e.command, Handshake)
    )
    assert "set_param" in hello.command.metadata["extensions"]
    client.send(SetParam("/arm/robot_description", URDF).encode())
    with Ros2Process.node(
        "echo", "/arm/robot_description", "std_msgs/msg/String", "1", "--latched"
    ) as echo:
        assert echo.expect_json("msg") == {"data": URDF}


def test_other_parameters_are_refused(client: RawClient) -> None:
    client.send(SetParam("/use_sim_time", True).encode())
    event = client.expect(
        lambda e: isinstance(e, CommandReceived) and isinstance(e.command, ErrorMessage),
        timeout=10,
    )
    assert "'/use_sim_time'" in event.command.text
    assert "no global parameter server" in event.command.text
