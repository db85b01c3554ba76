"""The simulation-side ROS-TCP client (what Unity's ROSConnection does, in Python).

`Connector` publishes, subscribes, calls ROS services and implements services that
ROS calls, over one TCP connection that it keeps alive, re-establishes with back-off
and re-registers on its own.
"""

from __future__ import annotations

from simbridge.connector.actions import ActionClient, ActionServer
from simbridge.connector.calls import ServiceHandler
from simbridge.connector.connector import Connector
from simbridge.connector.handles import MessageCallback, MessageTap, Publisher, Subscription
from simbridge.connector.options import ConnectorOptions
from simbridge.connector.ros2_action_server import (
    AnyServerGoal,
    Ros2ActionServer,
    Ros2ServerGoal,
    action_server,
)
from simbridge.connector.ros2_actions import Ros2ActionClient, Ros2ClientGoal, action_client
from simbridge.connector.stats import ConnectorStats

__all__ = [
    "ActionClient",
    "ActionServer",
    "AnyServerGoal",
    "Connector",
    "ConnectorOptions",
    "ConnectorStats",
    "MessageCallback",
    "MessageTap",
    "Publisher",
    "Ros2ActionClient",
    "Ros2ActionServer",
    "Ros2ClientGoal",
    "Ros2ServerGoal",
    "ServiceHandler",
    "Subscription",
    "action_client",
    "action_server",
]
