"""The exception hierarchy: one root, one subclass per layer."""

from __future__ import annotations

__all__ = [
    "AppError",
    "ClusterError",
    "ConnectorError",
    "EndpointError",
    "GymError",
    "MessageError",
    "PlanningError",
    "ProtocolError",
    "ServiceError",
    "SimError",
    "SimbridgeError",
    "UnknownMessageTypeError",
    "UrdfError",
]


class SimbridgeError(Exception):
    """Root of every error simbridge raises on purpose."""


class MessageError(SimbridgeError):
    """A message type, definition or payload is invalid."""


class UnknownMessageTypeError(MessageError, KeyError):
    """A message type name is not known; the text names close matches."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


class ProtocolError(SimbridgeError):
    """Bytes on the wire break the ROS-TCP protocol."""


class EndpointError(SimbridgeError):
    """The endpoint or one of its backends failed."""


class ConnectorError(SimbridgeError):
    """The connector (simulation-side client) failed."""


class ServiceError(SimbridgeError):
    """A service call failed, timed out or has no provider."""


class SimError(SimbridgeError):
    """The simulator was given something it cannot build or run."""


class UrdfError(SimError):
    """A URDF (or xacro) document is malformed; the text names the element."""


class PlanningError(SimbridgeError):
    """Motion planning failed: unreachable goal, collision, bad request."""


class AppError(SimbridgeError):
    """An application (demo) failed."""


class GymError(SimbridgeError):
    """A learning environment (simbridge.gym) was configured or used wrongly."""


class ClusterError(SimbridgeError):
    """Work on a Ray cluster (simbridge.cluster) could not start or failed there."""
