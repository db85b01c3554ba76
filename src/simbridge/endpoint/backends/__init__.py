"""Backends: the ROS graphs an endpoint can bridge into. `base` is the interface, `local`
the embedded bus; `ros1` and `ros2` are packages whose faces load rospy or rclpy only when
a name that needs them is used. Names here are loaded on first use (PEP 562)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from simbridge.lazy import lazy_face

if TYPE_CHECKING:
    from simbridge.endpoint.backends.base import (
        Backend,
        BackendActionGoal,
        BackendPublisher,
        BackendServiceServer,
        BackendSubscription,
        MessageCallback,
        ServiceHandler,
        TopicInfo,
    )
    from simbridge.endpoint.backends.factory import BACKENDS, make_backend
    from simbridge.endpoint.backends.local import LocalBus

__all__ = [
    "BACKENDS",
    "Backend",
    "BackendActionGoal",
    "BackendPublisher",
    "BackendServiceServer",
    "BackendSubscription",
    "LocalBus",
    "MessageCallback",
    "ServiceHandler",
    "TopicInfo",
    "make_backend",
]

__getattr__, __dir__ = lazy_face(
    __name__,
    {
        "BACKENDS": "factory",
        "Backend": "base",
        "BackendActionGoal": "base",
        "BackendPublisher": "base",
        "BackendServiceServer": "base",
        "BackendSubscription": "base",
        "LocalBus": "local",
        "MessageCallback": "base",
        "ServiceHandler": "base",
        "TopicInfo": "base",
        "make_backend": "factory",
    },
)
