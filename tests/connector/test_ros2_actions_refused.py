"""A connector's ROS 2 action client refuses endpoints that did not announce the `actions`
extension (the local bus here; a Unity or ROS 1 endpoint alike), naming what they offer."""

from __future__ import annotations

from pathlib import Path

import pytest

from simbridge.connector import ActionClient, Connector, Ros2ActionClient, action_client
from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.endpoint.backends import LocalBus
from simbridge.errors import ConnectorError, MessageError
from simbridge.messages import ROS2_STORE, MessageRegistry

ASSETS = Path(__file__).parent.parent / "assets" / "ros2_actions"


def test_ros2_endpoint_without_the_extension_is_refused() -> None:
    registry = MessageRegistry(store=ROS2_STORE)
    registry.load_packages(ASSETS)
    with (
        EndpointThread(EndpointOptions(port=0), LocalBus("ROS2")) as endpoint,
        Connector("127.0.0.1", endpoint.port, registry=registry).connect() as ros,
    ):
        assert ros.protocol == "ROS2"
        assert "actions" not in ros.extensions
        with pytest.raises(ConnectorError, match="does not offer ROS 2 actions") as info:
            action_client(ros, "/fibonacci", "test_msgs/Fibonacci")
        assert "'stats'" in str(info.value)  # what the endpoint does offer


def test_action_client_picks_actionlib_on_a_ros1_endpoint() -> None:
    with EndpointThread() as endpoint, Connector("127.0.0.1", endpoint.port).connect() as ros:
        client = action_client(ros, "/arm/follow", "control_msgs/FollowJointTrajectory")
        try:
            assert isinstance(client, ActionClient)
        finally:
            client.close()


def test_unknown_action_type_is_named_before_anything_is_sent() -> None:
    unconnected = Connector("127.0.0.1", 9)
    with pytest.raises(MessageError, match="test_msgs/FibonacciGoal"):
        Ros2ActionClient(unconnected, "/fibonacci", "test_msgs/Fibonacci")


def test_a_goal_too_big_for_one_system_command_is_refused() -> None:
    registry = MessageRegistry(store=ROS2_STORE)
    registry.load_packages(ASSETS)
    client = Ros2ActionClient(
        Connector("127.0.0.1", 9, registry=registry), "/fib", "test_msgs/Fibonacci"
    )
    with pytest.raises(ConnectorError, match="800,000 bytes is more than the actions extension"):
        client.send_goal(b"\0" * 800_000)
    assert not client.goals
