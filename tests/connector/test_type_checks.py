"""The connector checks type names when a topic or service is registered, so a typo fails
on the line that wrote it, naming the closest known type."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from simbridge.connector import Connector
from simbridge.errors import ConnectorError
from simbridge.messages import MessageRegistry


@pytest.mark.parametrize(
    ("register", "message"),
    [
        (
            lambda c: c.register_publisher("/x", "geometry_msgs/Twst"),
            r"publisher /x: unknown message type 'geometry_msgs/Twst'.*did you mean "
            r"geometry_msgs/Twist",
        ),
        (
            lambda c: c.subscribe("/y", "std_msgs/Strin", print),
            r"subscriber /y: unknown message type 'std_msgs/Strin'.*did you mean std_msgs/String",
        ),
        (
            lambda c: c.register_ros_service("/s", "std_srvs/Trigge"),
            r"service /s: unknown service type 'std_srvs/Trigge'.*did you mean std_srvs/Trigger",
        ),
        (
            lambda c: c.implement_service("/s", "std_srvs/SetBol", lambda r: r),
            r"service /s: unknown service type 'std_srvs/SetBol'.*did you mean std_srvs/SetBool",
        ),
        (
            lambda c: c.register_publisher("/x", "mypkg/Foo"),
            r"package 'mypkg' is unknown.*pass raw=True",
        ),
    ],
)
def test_an_unknown_type_fails_at_registration(
    register: Callable[[Connector], object], message: str
) -> None:
    connector = Connector("127.0.0.1", 9)  # never connected: the check needs no endpoint
    with pytest.raises(ConnectorError, match=message):
        register(connector)


def test_raw_registrations_take_types_only_the_ros_side_knows() -> None:
    connector = Connector("127.0.0.1", 9)
    connector.register_publisher("/x", "mypkg/Foo", raw=True)
    connector.subscribe("/y", "mypkg/Bar", print, raw=True)
    connector.register_ros_service("/s", "mypkg/Srv", raw=True)
    connector.implement_service("/t", "mypkg/Srv", lambda r: r, raw=True)


def test_types_of_either_ros_generation_pass() -> None:
    connector = Connector("127.0.0.1", 9)
    connector.register_publisher("/goal", "control_msgs/FollowJointTrajectoryActionGoal")
    connector.register_publisher("/image", "sensor_msgs/msg/Image")


def test_a_given_registry_is_the_only_one_asked() -> None:
    registry = MessageRegistry()
    registry.add_message("sb_custom/Reading", "float64 value\n")
    connector = Connector("127.0.0.1", 9, registry=registry)
    connector.register_publisher("/r", "sb_custom/Reading")
    with pytest.raises(ConnectorError, match="unknown message type 'std_msgs/Strin'"):
        connector.register_publisher("/s", "std_msgs/Strin")
