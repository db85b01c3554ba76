"""Writes deferred to the end of the input callback that caused them.

Everything one read brings in (a client's frames, a ROS publisher's messages) is
forwarded first and written afterwards, one write per connection, so bursts still
leave in batches. Writing at the end of that read callback rather than in a
`call_soon` saves a pass through the event loop (and its `epoll_wait`) on every hop
of a round trip. A write caused outside an input callback (a timer, a task, another
thread's callback) still leaves at the end of the loop iteration.
"""

from __future__ import annotations

import asyncio
import logging
import weakref
from collections.abc import Callable

__all__ = ["DeferredWrites", "deferred_writes"]

_log = logging.getLogger("simbridge.endpoint")

Flush = Callable[[], None]


class DeferredWrites:
    """Flush callbacks due at the end of the current input callback (or loop iteration)."""

    __slots__ = ("__weakref__", "_depth", "_due", "_loop", "_scheduled")

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self._loop = loop
        self._due: list[Flush] = []
        self._depth = 0
        self._scheduled = False

    def defer(self, flush: Flush) -> None:
        """Call `flush` once the input being handled is done; the caller calls this once
        per batch (it keeps its own flag of being due)."""
        self._due.append(flush)
        if not self._depth and not self._scheduled:
            self._scheduled = True
            self._loop.call_soon(self.run)

    def hold(self) -> None:
        """An input callback starts: what it defers waits for its `release`."""
        self._depth += 1

    def release(self) -> None:
        """The input callback is done: run what it deferred (the outermost one runs all)."""
        self._depth -= 1
        if not self._depth and self._due:
            self.run()

    def run(self) -> None:
        """Run every deferred flush, including those the flushes themselves defer."""
        self._scheduled = False
        while self._due:
            due, self._due = self._due, []
            for flush in due:
                try:
                    flush()
                except Exception:  # one failing connection must not hold up the others
                    _log.exception("a deferred write failed")


_by_loop: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, DeferredWrites] = (
    weakref.WeakKeyDictionary()
)


def deferred_writes(loop: asyncio.AbstractEventLoop) -> DeferredWrites:
    """The one `DeferredWrites` of `loop` (shared by every connection on it)."""
    writes = _by_loop.get(loop)
    if writes is None:
        writes = _by_loop[loop] = DeferredWrites(loop)
    return writes
