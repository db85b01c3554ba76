"""Publishers of clients that left (or removed them), delivering what they accepted first.

A client may publish its last results and close its socket at once: the endpoint has
read and accepted every message by then, but the graph may still hold some (DDS samples
not yet acknowledged, bytes queued for a slow ROS 1 subscriber). Closing the publisher
there and then would drop them. Each goes here instead: `BackendPublisher.drain` runs in
the background, bounded by the endpoint's `drain_timeout`, while the event loop keeps
serving every other client, and the publisher closes afterwards. A bound that is hit is
logged with the count still undelivered and counted in `__stats`.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Iterable

from simbridge.endpoint.backends.base import BackendPublisher

__all__ = ["PublisherDrains"]

log = logging.getLogger("simbridge.endpoint")


class PublisherDrains:
    """Drains and then closes publishers in the background; close() waits for them all."""

    def __init__(self, loop: asyncio.AbstractEventLoop, timeout: float) -> None:
        self._loop = loop
        self._timeout = timeout
        self._tasks: set[asyncio.Task[None]] = set()
        self.drained = 0
        """Publishers closed after delivering everything they accepted."""
        self.timeouts = 0
        """Publishers closed when the bound was hit with messages still undelivered."""
        self.undelivered = 0
        """Messages those publishers may still have held (at most) when they closed."""

    def add(self, peer: str, publishers: Iterable[tuple[str, BackendPublisher]]) -> None:
        """Drain each of `peer`'s `(topic, publisher)` pairs, then close it (at once when
        nothing is in flight: the topic leaves the graph before the next request)."""
        for topic, publisher in publishers:
            if not publisher.in_flight():
                self.drained += 1
                publisher.close()
                continue
            task = self._loop.create_task(self._drain(peer, topic, publisher))
            self._tasks.add(task)
            task.add_done_callback(self._tasks.discard)

    async def _drain(self, peer: str, topic: str, publisher: BackendPublisher) -> None:
        started = time.monotonic()
        left = -1
        try:
            left = await publisher.drain(self._timeout)
        except asyncio.CancelledError:
            raise
        except Exception:
            log.exception("client %s: draining its publisher of %s failed", peer, topic)
        finally:
            publisher.close()
        if left == 0:
            self.drained += 1
            log.debug("client %s: %s drained in %.3f s", peer, topic, time.monotonic() - started)
            return
        self.timeouts += 1
        self.undelivered += max(left, 0)
        log.warning(
            "client %s left: its publisher of %s still held %s undelivered message(s) after "
            "%.1f s (drain timeout %g s); closed anyway",
            peer,
            topic,
            f"up to {left}" if left > 0 else "an unknown number of",
            time.monotonic() - started,
            self._timeout,
        )

    @property
    def draining(self) -> int:
        """Publishers still draining."""
        return len(self._tasks)

    async def close(self) -> None:
        """Wait for every drain under way (each is bounded by the timeout)."""
        while self._tasks:
            await asyncio.gather(*list(self._tasks), return_exceptions=True)

    def stats(self) -> dict[str, int]:
        """Counters for `__stats`."""
        return {
            "drained_publishers": self.drained,
            "drain_timeouts": self.timeouts,
            "drain_undelivered": self.undelivered,
            "draining_publishers": self.draining,
        }
