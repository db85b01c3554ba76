"""Endpoint settings."""

from __future__ import annotations

from dataclasses import dataclass

from simbridge.protocol import DEFAULT_MAX_FRAME_SIZE

__all__ = ["EndpointOptions"]


@dataclass(frozen=True, slots=True)
class EndpointOptions:
    """How the endpoint listens and how hard it protects itself.

    Every buffer is bounded: frames by `max_frame_size`, a slow client's kernel-side
    backlog by `write_high_water`, queued messages by each registration's queue_size,
    control frames (service replies, errors) by `max_control_backlog`, and what one
    client may hold by `max_registrations`, `max_inflight_calls` and `max_action_goals`.
    In bytes, all partly received large frames, queued messages and queued control frames
    together stay within `max_memory`, each client within its share (`client_memory`).
    """

    host: str = "127.0.0.1"
    port: int = 10000
    max_frame_size: int = DEFAULT_MAX_FRAME_SIZE
    keepalive_interval: float = 1.0
    """Send a keepalive to a client that was sent nothing for this long (seconds)."""
    idle_timeout: float = 10.0
    """Close a client that sent nothing (not even a keepalive) for this long; 0 disables."""
    service_timeout: float = 30.0
    """Longest wait for a service answer, in either direction."""
    write_high_water: int = 1024 * 1024
    """Bytes buffered for a client before its per-topic queues take over."""
    max_control_backlog: int = 10_000
    """Control frames queued for a stalled client before it is disconnected."""
    warn_interval: float = 1.0
    """Shortest time between two drop/error summaries sent to one client."""
    max_clients: int = 1_000
    """Connections served at once; more are told so and closed."""
    max_registrations: int = 10_000
    """Publishers + subscriptions + services one client may hold at once."""
    max_inflight_calls: int = 1_000
    """Service calls one client may have waiting for an answer at once."""
    max_action_goals: int = 100
    """Action goals one client may have in flight at once (the `actions` extension)."""
    max_memory: int = 1024 * 1024 * 1024
    """Bytes all clients together may make the endpoint buffer (--max-memory-mb)."""
    client_memory: int = 0
    """Bytes one client may make it buffer; 0: an eighth of `max_memory`, and at least
    one largest frame plus 4 MiB (within `max_memory`)."""
    frame_timeout: float = 10.0
    """A frame still incomplete this long after the previous one completed closes the
    client, unless its bytes arrive at `min_frame_rate` or faster (slow senders)."""
    min_frame_rate: float = 64 * 1024
    """Bytes per second a client sending a frame must keep up after `frame_timeout`."""
    max_errors_per_interval: int = 10
    """`__error`s about unregistered topics sent to one client per `warn_interval`."""
    splice: bool = True
    """Move a large message bound for a single native ROS 1 subscriber from the client's
    socket to the subscriber's in the kernel (Linux splice), without copying it through
    the endpoint (`endpoint.speed.splice`; --no-splice turns it off)."""
    drain_timeout: float = 5.0
    """When a client leaves, how long each of its publishers may take to deliver what it
    accepted before it is closed (in the background; `endpoint.session.drain`)."""
    evict_after: float = 2.0
    """When the endpoint is full, a client connected this long that has sent no complete
    request (only keepalives or a partial frame) makes room for a new one."""

    @property
    def client_share(self) -> int:
        """Bytes of `max_memory` one client may hold."""
        if self.client_memory:
            return min(self.client_memory, self.max_memory)
        floor = self.max_frame_size + 4 * 1024 * 1024
        return min(self.max_memory, max(self.max_memory // 8, floor))
