"""Busy polling: after handling I/O the endpoint's loop polls a while before it sleeps.

A reply that arrives within the spin is handled without waking a sleeping process, which
costs tens of microseconds per message on the 2-core virtual machine the benchmarks run on.
It trades CPU for latency, as Linux's `busy_poll` does: off unless asked for
(`simbridge endpoint --busy-poll-us N`, or an asyncio loop built on this selector).
"""

from __future__ import annotations

import os
import selectors
import time

from simbridge.errors import EndpointError

__all__ = ["MAX_BUSY_POLL_US", "BusyPollSelector"]

MAX_BUSY_POLL_US = 100_000
"""The longest spin accepted (0.1 s); longer only burns CPU."""


class BusyPollSelector(selectors.DefaultSelector):
    """The platform's selector (epoll on Linux) that, once events came, polls without
    blocking for up to `spin_us` (yielding the CPU between polls) before it blocks again.

    A loop that found nothing in its last wait sleeps as before, so an idle endpoint costs
    nothing; a spin never outlasts the timeout asyncio passes for its next timer. `polls`,
    `hits` and `spin_seconds` count the non-blocking polls, the spins that found an event,
    and the time spent spinning.
    """

    def __init__(self, spin_us: float) -> None:
        if not 0 <= spin_us <= MAX_BUSY_POLL_US:
            raise EndpointError(
                f"busy-poll time {spin_us!r} µs is out of range: expected 0 to {MAX_BUSY_POLL_US}"
            )
        super().__init__()
        self.spin = spin_us / 1e6
        self.polls = 0
        self.hits = 0
        self.spin_seconds = 0.0
        self._worked = False

    def select(self, timeout: float | None = None) -> list[tuple[selectors.SelectorKey, int]]:
        if timeout is not None and timeout <= 0:  # asyncio has callbacks ready: just look
            ready = super().select(0)
            self._worked = self._worked or bool(ready)
            return ready
        if self.spin and self._worked:
            start = now = time.perf_counter()
            end = start + (self.spin if timeout is None else min(self.spin, timeout))
            poll = super().select
            while now < end:
                ready = poll(0)
                self.polls += 1
                if ready:
                    self.hits += 1
                    self.spin_seconds += time.perf_counter() - start
                    return ready
                os.sched_yield()  # another task runnable on this CPU goes first
                now = time.perf_counter()
            self.spin_seconds += now - start
            if timeout is not None:
                timeout = max(0.0, timeout - (now - start))
        ready = super().select(timeout)
        self._worked = bool(ready)
        return ready
