"""A ROS 2 publisher that may not drop (queue_size 0): reliable, keep-all, pushing back.

DDS keeps every sample of a keep-all publisher until each reliable subscription has
acknowledged it, but only up to its resource limits: past them Fast DDS's write blocks
(100 ms, holding the GIL in rclpy, so the whole endpoint stops) and then fails, losing the
message. So the endpoint never lets DDS get there. It counts the samples handed over
since DDS last said all were acknowledged; at `UNCONFIRMED_LIMIT` messages (or
`UNCONFIRMED_BYTES`) it tells the session (`BackendPublisher.watch_backlog`), which stops
reading the client's socket (`endpoint.session.pushback`), holds what that read already
brought, and asks DDS every millisecond until everything was acknowledged; then it
publishes what it held and the client is read again. A flat-out client is slowed to what
the subscribers take, never dropped. Only a subscriber stuck longer than the session's
push-back limit lets the held queue fill up to `HELD_BYTES`; past that the oldest are
dropped, counted (`lossless_dropped`) and logged.
"""

from __future__ import annotations

import asyncio
import logging
from collections import deque
from collections.abc import Callable
from typing import Any

from rclpy.qos import QoSProfile

from simbridge.endpoint.backends.ros2.entities import NodeEntity, NodeSide, Ros2Publisher

__all__ = ["HELD_BYTES", "UNCONFIRMED_BYTES", "UNCONFIRMED_LIMIT", "LosslessRos2Publisher"]

_log = logging.getLogger(__name__)

UNCONFIRMED_LIMIT = 2048
"""Messages handed to DDS and not yet known acknowledged, past which the client is pushed
back on (well below Fast DDS's keep-all limits: it blocked at 10,000 Twists here)."""
UNCONFIRMED_BYTES = 64 << 20
"""The same in bytes (a keep-all history of camera images)."""
HELD_BYTES = 256 << 20
"""Bytes held while pushed back (what reads brought before reading stopped, or after the
push-back limit let the client go on); past that the oldest are dropped and counted."""
ASK_EVERY = 0.001
"""Seconds between two questions to DDS while pushed back."""


class LosslessRos2Publisher(Ros2Publisher):
    """A keep-all publisher that holds messages instead of overrunning DDS (see module)."""

    def __init__(
        self,
        backend: NodeSide,
        topic: str,
        cls: Any,
        qos: QoSProfile,
        loop: asyncio.AbstractEventLoop,
        *,
        live: set[NodeEntity],
    ) -> None:
        super().__init__(backend, topic, cls, qos, loop, live=live)
        self._unconfirmed = 0
        self._unconfirmed_bytes = 0
        self._held: deque[bytes] = deque()
        self._held_bytes = 0
        self._watchers: list[tuple[Callable[[], None], Callable[[], None]]] = []
        self._behind = False
        self._timer: asyncio.TimerHandle | None = None

    def publish(self, payload: bytes | bytearray) -> None:
        if self._behind and not self.closed:
            self._hold(bytes(payload))  # a lent bytearray goes back to the client's decoder
            return
        self._hand_over(payload)

    def _hand_over(self, payload: bytes | bytearray) -> None:
        super().publish(payload)
        self._unconfirmed += 1
        self._unconfirmed_bytes += len(payload)
        if self._unconfirmed >= UNCONFIRMED_LIMIT or self._unconfirmed_bytes >= UNCONFIRMED_BYTES:
            self._fall_behind()

    def _hold(self, payload: bytes) -> None:
        held = self._held
        while held and self._held_bytes + len(payload) > HELD_BYTES:
            self._held_bytes -= len(held.popleft())
            counters = self._backend.counters
            counters["lossless_dropped"] += 1
            if counters["lossless_dropped"] == 1:
                _log.warning(
                    "%s (queue_size 0): a subscriber took nothing for longer than the "
                    "push-back limit and %d MiB are held; dropping the oldest",
                    self.topic,
                    HELD_BYTES >> 20,
                )
        held.append(payload)
        self._held_bytes += len(payload)

    def _fall_behind(self) -> None:
        if self._behind:
            return
        self._behind = True
        counters = self._backend.counters
        counters["lossless_pushbacks"] += 1
        for behind, _ in list(self._watchers):
            behind()
        self._timer = self._loop.call_later(ASK_EVERY, self._ask)

    def _ask(self) -> None:
        """While behind: once DDS has every sample acknowledged, publish what was held
        (pushing back again at the limit), and read the client again when all went."""
        self._timer = None
        if self.closed:
            return
        if not self.all_acked():
            self._timer = self._loop.call_later(ASK_EVERY, self._ask)
            return
        self._unconfirmed = self._unconfirmed_bytes = 0
        self._behind = False
        held = self._held
        while held and not self._behind:
            payload = held.popleft()
            self._held_bytes -= len(payload)
            self._hand_over(payload)
        if not self._behind:
            for _, caught_up in list(self._watchers):
                caught_up()

    def watch_backlog(self, behind: Callable[[], None], caught_up: Callable[[], None]) -> bool:
        """Call `behind()` while DDS has as much unacknowledged as it may, `caught_up()`
        once everything was acknowledged and nothing is held."""
        self._watchers.append((behind, caught_up))
        if self._behind:
            behind()
        return True

    def in_flight(self) -> bool:
        return self._behind or super().in_flight()

    def undelivered(self) -> int:
        """Held messages and those DDS may not have had acknowledged yet."""
        return len(self._held) + self._unconfirmed

    async def drain(self, timeout: float) -> int:
        """Wait until nothing is held and DDS has every sample acknowledged, or `timeout`
        s passed; returns 0, or `undelivered()`."""
        deadline = self._loop.time() + timeout
        while self._behind and not self.closed:
            if self._loop.time() >= deadline:
                return self.undelivered()
            await asyncio.sleep(ASK_EVERY * 5)
        return await self._acked_within(max(0.0, deadline - self._loop.time()))

    def _destroy(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        self._held.clear()
        self._held_bytes = 0
        self._watchers.clear()
        super()._destroy()
