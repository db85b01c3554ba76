"""One client connection of the endpoint: the session (frames in, registrations), its
bounded output, its service calls and action goals, read back-pressure, and counters."""

from __future__ import annotations

from typing import TYPE_CHECKING

from simbridge.lazy import lazy_face

if TYPE_CHECKING:
    from simbridge.endpoint.session.session import ClientSession, SessionHost
    from simbridge.endpoint.session.stats import SessionStats

__all__ = ["ClientSession", "SessionHost", "SessionStats"]

__getattr__, __dir__ = lazy_face(
    __name__,
    {"ClientSession": "session", "SessionHost": "session", "SessionStats": "stats"},
)
