"""Description of a ROS service type."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ServiceInfo"]


@dataclass(frozen=True, slots=True)
class ServiceInfo:
    """A service type: its canonical name, request/response message types and genmsg md5."""

    name: str
    request: str
    response: str
    md5: str
