"""Counters an endpoint keeps per client, visible through `__stats` and logs."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

__all__ = ["SessionStats"]


@dataclass(slots=True)
class SessionStats:
    """What one client connection moved, dropped and got wrong."""

    frames_in: int = 0
    bytes_in: int = 0
    frames_out: int = 0
    bytes_out: int = 0
    errors_sent: int = 0
    goals_sent: int = 0
    """Action goals the client sent (the `actions` extension)."""
    goals_refused: int = 0
    """Of those, goals that ended without a result: refused by the endpoint (limit, unknown
    type, no server) or rejected by the action server."""
    feedback_dropped: int = 0
    """Action feedback messages dropped while the client was not reading."""
    served_goals: int = 0
    """Goals ROS clients sent to the actions this client serves (`action_servers`)."""
    served_goals_rejected: int = 0
    """Of those, goals rejected: by the client's answer, or by the endpoint (too large)."""
    served_goals_aborted: int = 0
    """Of those, goals the client had not ended (by a result or a rejection) when it
    unserved their action or left."""
    published: Counter[str] = field(default_factory=Counter)
    """Messages handed to the graph per topic (what ROS then does with them is the
    backend's: its counters, and the topic's QoS on ROS 2)."""
    dropped: Counter[str] = field(default_factory=Counter)
    """Messages dropped per topic because the client fell behind its queue_size."""

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {
            "frames_in": self.frames_in,
            "bytes_in": self.bytes_in,
            "frames_out": self.frames_out,
            "bytes_out": self.bytes_out,
            "errors_sent": self.errors_sent,
            "goals_sent": self.goals_sent,
            "goals_refused": self.goals_refused,
            "feedback_dropped": self.feedback_dropped,
            "served_goals": self.served_goals,
            "served_goals_rejected": self.served_goals_rejected,
            "served_goals_aborted": self.served_goals_aborted,
            "published": dict(self.published),
            "published_total": sum(self.published.values()),
            "dropped": dict(self.dropped),
            "dropped_total": sum(self.dropped.values()),
        }
