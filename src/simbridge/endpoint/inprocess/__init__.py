"""In-process ROS-like nodes and their ROS 1 actions, on the endpoint's own backend (the
embedded local bus needs no ROS install): apps and tests talk to the sim without a socket."""

from __future__ import annotations

from typing import TYPE_CHECKING

from simbridge.lazy import lazy_face

if TYPE_CHECKING:
    from simbridge.endpoint.inprocess.actions import (
        ClientGoal,
        NodeActionClient,
        NodeActionServer,
        NodeTransport,
        ServerGoal,
    )
    from simbridge.endpoint.inprocess.node import Node, NodePublisher

__all__ = [
    "ClientGoal",
    "Node",
    "NodeActionClient",
    "NodeActionServer",
    "NodePublisher",
    "NodeTransport",
    "ServerGoal",
]

__getattr__, __dir__ = lazy_face(
    __name__,
    {
        "ClientGoal": "actions",
        "Node": "node",
        "NodeActionClient": "actions",
        "NodeActionServer": "actions",
        "NodePublisher": "node",
        "NodeTransport": "actions",
        "ServerGoal": "actions",
    },
)
