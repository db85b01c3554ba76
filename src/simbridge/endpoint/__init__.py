"""The ROS-TCP endpoint: asyncio server, per-client sessions, pluggable backends.

Names are loaded on first use (PEP 562), so importing one part (say a ROS 1 tool in
`backends.ros1`) does not load the server, the sessions or any ROS library.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from simbridge.lazy import lazy_face

if TYPE_CHECKING:
    from simbridge.endpoint.backends.base import Backend, TopicInfo
    from simbridge.endpoint.backends.factory import BACKENDS, make_backend
    from simbridge.endpoint.backends.local import LocalBus
    from simbridge.endpoint.inprocess.actions import NodeActionClient, NodeActionServer
    from simbridge.endpoint.inprocess.node import Node, NodePublisher
    from simbridge.endpoint.options import EndpointOptions
    from simbridge.endpoint.runner import EndpointThread
    from simbridge.endpoint.server import EndpointServer
    from simbridge.endpoint.session.session import ClientSession
    from simbridge.endpoint.typecheck import RegistryTypeCheck, TypeCheck

__all__ = [
    "BACKENDS",
    "Backend",
    "ClientSession",
    "EndpointOptions",
    "EndpointServer",
    "EndpointThread",
    "LocalBus",
    "Node",
    "NodeActionClient",
    "NodeActionServer",
    "NodePublisher",
    "RegistryTypeCheck",
    "TopicInfo",
    "TypeCheck",
    "make_backend",
]

__getattr__, __dir__ = lazy_face(
    __name__,
    {
        "BACKENDS": "backends.factory",
        "Backend": "backends.base",
        "ClientSession": "session.session",
        "EndpointOptions": "options",
        "EndpointServer": "server",
        "EndpointThread": "runner",
        "LocalBus": "backends.local",
        "Node": "inprocess.node",
        "NodeActionClient": "inprocess.actions",
        "NodeActionServer": "inprocess.actions",
        "NodePublisher": "inprocess.node",
        "RegistryTypeCheck": "typecheck",
        "TopicInfo": "backends.base",
        "TypeCheck": "typecheck",
        "make_backend": "backends.factory",
    },
)
