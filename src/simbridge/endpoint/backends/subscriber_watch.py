"""A publisher's subscriber-count watchers, for graphs that say "the count may have
changed" on a thread of their own (rospy's peer listener, rclpy's matched event).

The graph's thread only schedules a look on the event loop; there the count is read
again and the watchers are called when it differs from what they were last told.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable

__all__ = ["SubscriberWatch"]


class SubscriberWatch:
    """The `watch_subscribers` callbacks of one publisher."""

    def __init__(
        self,
        loop: asyncio.AbstractEventLoop,
        count: Callable[[], int],
        closed: Callable[[], bool],
    ) -> None:
        self._loop = loop
        self._count = count
        self._closed = closed
        self._watchers: list[Callable[[int], None]] = []
        self._reported = -1

    def add(self, callback: Callable[[int], None]) -> bool:
        """Call `callback(count)` now and whenever the count changes; True (supported)."""
        self._watchers.append(callback)
        self._reported = self._count()
        callback(self._reported)
        return True

    def changed(self) -> None:
        """The count may have changed (from any thread): look again on the event loop."""
        with contextlib.suppress(RuntimeError):  # a closed loop: the endpoint is going away
            self._loop.call_soon_threadsafe(self._report)

    def _report(self) -> None:
        if self._closed() or not self._watchers:
            return
        count = self._count()
        if count != self._reported:
            self._reported = count
            for callback in list(self._watchers):
                callback(count)
