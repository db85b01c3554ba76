"""TCP back-pressure towards a client whose messages the ROS graph is not taking.

A topic registered with queue_size 0 must not lose messages. When a ROS subscriber of
such a topic falls behind, the backend says so (`BackendPublisher.watch_backlog`) and the
client's session stops reading its socket until the subscriber has caught up: the
client's own bounded queues wait instead of the endpoint piling up its camera images
(hundreds of MB of freshly allocated memory, read as fast as the client can send them,
on the CPU the subscriber needs). A subscriber that stays behind longer than the limit
no longer holds the client: reading resumes and the topic falls back to holding and
dropping, as before.
"""

from __future__ import annotations

import asyncio
from typing import Protocol

__all__ = ["PUSHBACK_LIMIT", "ReadGate", "ReadPushback", "pushback_limit"]

PUSHBACK_LIMIT = 2.0
"""Seconds one episode may keep a client's socket unread at most."""


def pushback_limit(*timeouts: float) -> float:
    """The episode limit for an endpoint with these client timeouts (idle, slow frame; 0
    is off): PUSHBACK_LIMIT, or half the shortest, so a client held unread is never
    closed as idle or as a slow sender for it."""
    return min([PUSHBACK_LIMIT, *(t / 2 for t in timeouts if t > 0)])


class Pausable(Protocol):
    """What pausing a client's reading needs of its transport."""

    def pause_reading(self) -> None: ...
    def resume_reading(self) -> None: ...
    def is_closing(self) -> bool: ...


class ReadGate:
    """A transport read only while none of its holders has paused it (back-pressure and
    a splice of a large message each pause it for their own reasons)."""

    __slots__ = ("_held", "transport")

    def __init__(self) -> None:
        self.transport: asyncio.Transport | None = None
        self._held: set[str] = set()

    def pause(self, holder: str) -> None:
        """`holder` wants reading stopped."""
        if not self._held and self.transport is not None and not self.transport.is_closing():
            self.transport.pause_reading()
        self._held.add(holder)

    def resume(self, holder: str) -> None:
        """`holder` is done; reading resumes once no holder is left."""
        if holder not in self._held:
            return
        self._held.discard(holder)
        if not self._held and self.transport is not None and not self.transport.is_closing():
            self.transport.resume_reading()

    def holder(self, name: str) -> Pausable:
        """`name`'s handle, shaped like the transport's pause and resume."""
        return _Holder(self, name)


class _Holder:
    __slots__ = ("_gate", "_name")

    def __init__(self, gate: ReadGate, name: str) -> None:
        self._gate, self._name = gate, name

    def pause_reading(self) -> None:
        self._gate.pause(self._name)

    def resume_reading(self) -> None:
        self._gate.resume(self._name)

    def is_closing(self) -> bool:
        transport = self._gate.transport
        return transport is None or transport.is_closing()


class ReadPushback:
    """Pauses reading one client's transport while any of its publishers is behind."""

    __slots__ = (
        "_behind",
        "_expired",
        "_limit",
        "_loop",
        "_paused",
        "_timer",
        "pauses",
        "transport",
    )

    def __init__(self, loop: asyncio.AbstractEventLoop, limit: float = PUSHBACK_LIMIT) -> None:
        self._loop = loop
        self._limit = limit
        self._behind: set[object] = set()
        self._timer: asyncio.TimerHandle | None = None
        self._expired = False
        self._paused = False
        self.pauses = 0
        """How many times reading was paused."""
        self.transport: Pausable | None = None

    def behind(self, key: object) -> None:
        """The publisher `key` fell behind: stop reading (unless this episode expired)."""
        if key in self._behind:
            return
        self._behind.add(key)
        if len(self._behind) > 1 or self._expired:
            return
        transport = self.transport
        if transport is None or transport.is_closing():
            return
        transport.pause_reading()
        self._paused = True
        self.pauses += 1
        self._timer = self._loop.call_later(self._limit, self._expire)

    def caught_up(self, key: object) -> None:
        """The publisher `key` caught up (or is gone): read again once none is behind."""
        if key not in self._behind:
            return
        self._behind.discard(key)
        if not self._behind:
            self._expired = False
            self._resume()

    def close(self) -> None:
        """Forget every publisher (the session ends)."""
        self._behind.clear()
        self._resume()
        self.transport = None

    def _expire(self) -> None:
        self._timer = None
        self._expired = True
        self._resume()

    def _resume(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if self._paused:
            self._paused = False
            transport = self.transport
            if transport is not None and not transport.is_closing():
                transport.resume_reading()
