"""Adaptive busy polling: after handling I/O the endpoint's loop polls a while before it sleeps,
when recent waits show that a spin would catch an answer.

A reply that arrives within the spin is handled without waking a sleeping process, which
costs tens of microseconds per message on the 2-core virtual machine the benchmarks run on.
The spin after reading from a socket is learned from the waits that followed. An answer
(data to read on another socket, as when a ROS node replies to what the sim sent) that came
within the limit sets it to twice that wait; a wait that outlasted the limit, a spin that
found nothing, or one that found the same socket again (a stream, where a spin buys little)
shrinks it. So a closed loop spins, and a stream, a slow sender or an idle endpoint does
not. A duty cap bounds the CPU a spin may take.
"""

from __future__ import annotations

import math
import os
import selectors
import time
from typing import TYPE_CHECKING

from simbridge.errors import EndpointError

if TYPE_CHECKING:
    from _typeshed import FileDescriptorLike

__all__ = ["DEFAULT_DUTY", "MAX_BUSY_POLL_US", "BusyPollSelector"]

MAX_BUSY_POLL_US = 100_000
"""The longest spin accepted (0.1 s); longer only burns CPU."""

DEFAULT_DUTY = 0.5
"""Spinning may take at most this share of wall time (half a core)."""

_BURST = 0.02
"""Unspent spin allowance saved up, in seconds: a quiet spell buys at most this much."""

_SHORTEST = 5e-6
"""A spin shrunk below this (seconds) is off until a short wait shows it would pay again."""


class BusyPollSelector(selectors.DefaultSelector):
    """The platform's selector (epoll on Linux) that, after reading from a socket, polls
    without blocking (yielding the CPU between polls) for as long as the answers to what it
    read have lately taken, up to `limit_us`, before it blocks again.

    A loop that found nothing in its last wait sleeps as before, and a spin never outlasts
    the timeout asyncio passes for its next timer or the allowance of `duty` seconds of spin
    per second of wall time. `polls`, `hits`, `misses` and `spin_seconds` count the
    non-blocking polls, the spins that found an event and those that did not, and the time
    spent spinning.
    """

    def __init__(self, limit_us: float, duty: float = DEFAULT_DUTY) -> None:
        if not 0 <= limit_us <= MAX_BUSY_POLL_US:
            raise EndpointError(
                f"busy-poll time {limit_us!r} µs is out of range: expected 0 to {MAX_BUSY_POLL_US}"
            )
        if not 0 < duty <= 1:
            raise EndpointError(f"busy-poll duty {duty!r} is out of range: expected (0, 1]")
        super().__init__()
        self.limit = limit_us / 1e6
        self.duty = duty
        self.polls = 0
        self.hits = 0
        self.misses = 0
        self.spin_seconds = 0.0
        self._windows: dict[int, float] = {}
        """Learned spin (s) after events on one file descriptor alone."""
        self._worked = False
        self._last: tuple[int, ...] = ()
        self._allowance = _BURST
        self._refilled = time.perf_counter()

    def window(self, fileobj: FileDescriptorLike) -> float:
        """The spin (seconds) the wait after events on `fileobj` alone starts with."""
        return self._windows.get(self.get_key(fileobj).fd, 0.0)

    def unregister(self, fileobj: FileDescriptorLike) -> selectors.SelectorKey:
        key = super().unregister(fileobj)
        self._windows.pop(key.fd, None)
        return key

    def select(self, timeout: float | None = None) -> list[tuple[selectors.SelectorKey, int]]:
        if timeout is not None and timeout <= 0:  # asyncio has callbacks ready: just look
            ready = super().select(0)
            if ready:
                self._worked = True
                self._answered(ready)
            return ready
        if not self._worked or len(self._last) != 1:  # idle, or busy on several: just wait
            ready = super().select(timeout)
            self._worked = bool(ready)
            if ready:
                self._answered(ready)
            return ready
        after = self._last[0]
        window = self._windows.get(after, 0.0)
        start = time.perf_counter()
        if window:
            ready = self._spin(after, window, start, timeout)
            if ready:
                if not self._answered(ready):  # a stream on the same socket: spin less
                    self._shrink(after)
                return ready
            if timeout is not None:
                timeout = max(0.0, timeout - (time.perf_counter() - start))
        ready = super().select(timeout)
        gap = time.perf_counter() - start  # from the end of the work to this event
        if gap > self.limit:
            self._windows.pop(after, None)
        if ready:
            if self._answered(ready) and gap <= self.limit:
                self._windows[after] = min(self.limit, max(self._windows.get(after, 0.0), 2 * gap))
        else:
            self._worked = False
        return ready

    def _answered(self, ready: list[tuple[selectors.SelectorKey, int]]) -> bool:
        """Whether `ready` reads from other sockets than the last reads did (an answer, not a
        stream); room to write is no answer."""
        last = self._last
        if len(ready) == 1:
            key, events = ready[0]
            if not events & selectors.EVENT_READ:
                return False
            self._last = (key.fd,)
            return key.fd not in last
        reads = tuple(key.fd for key, events in ready if events & selectors.EVENT_READ)
        if not reads:
            return False
        self._last = reads
        return all(fd not in last for fd in reads)

    def _shrink(self, after: int) -> None:
        half = self._windows.get(after, 0.0) / 2
        if half >= _SHORTEST:
            self._windows[after] = half
        else:
            self._windows.pop(after, None)

    def _spin(
        self, after: int, window: float, start: float, timeout: float | None
    ) -> list[tuple[selectors.SelectorKey, int]]:
        """Poll until an event, the window, the timeout or the duty allowance runs out."""
        self._allowance = min(_BURST, self._allowance + (start - self._refilled) * self.duty)
        self._refilled = start
        length = min(window, self._allowance, math.inf if timeout is None else timeout)
        now, end, poll = start, start + length, super().select
        ready: list[tuple[selectors.SelectorKey, int]] = []
        while now < end:
            ready = poll(0)
            self.polls += 1
            now = time.perf_counter()
            if ready:
                break
            os.sched_yield()  # another task runnable on this CPU goes first
            now = time.perf_counter()
        self.spin_seconds += now - start
        self._allowance -= now - start
        if ready:
            self.hits += 1
        elif length == window:  # the window itself was too short
            self.misses += 1
            self._shrink(after)
        return ready
