"""The exception hierarchy: one root, one subclass per layer."""

from __future__ import annotations

import difflib
from collections.abc import Iterable

__all__ = [
    "AppError",
    "ClusterError",
    "ConnectorError",
    "EndpointError",
    "GymError",
    "MessageError",
    "PerceptionError",
    "PlanningError",
    "ProtocolError",
    "ServiceError",
    "SimError",
    "SimbridgeError",
    "UnknownMessageTypeError",
    "UrdfError",
    "did_you_mean",
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


class PerceptionError(SimbridgeError):
    """Perception data (simbridge.perception) was configured or written wrongly."""


class ClusterError(SimbridgeError):
    """Work on a Ray cluster (simbridge.cluster) could not start or failed there."""


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """The hint every unknown key, option, type or name error ends with: "; did you mean
    'x'?" naming the choice closest to a mistyped `word`, or "" when none is close."""
    names = [str(choice) for choice in choices]
    close = difflib.get_close_matches(word, names, n=1, cutoff=0.6)
    if not close:
        close = [name for name in names if name.lower() == word.lower()][:1]
    return f"; did you mean '{close[0]}'?" if close else ""
