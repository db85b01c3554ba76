"""Backends: the ROS graphs an endpoint can bridge into."""

from __future__ import annotations

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
from simbridge.endpoint.backends.local import LocalBus

__all__ = [
    "Backend",
    "BackendActionGoal",
    "BackendPublisher",
    "BackendServiceServer",
    "BackendSubscription",
    "LocalBus",
    "MessageCallback",
    "ServiceHandler",
    "TopicInfo",
]
