"""Adaptive busy polling: after handling I/O the endpoint's loop polls a while before it sleeps,
when recent waits show that a spin would catch an answer.

A reply that arrives within the spin is handled without waking a sleeping process, which
costs tens of microseconds per message on the 2-core virtual machine the benchmarks run on.
The spin after reading from a socket is learned from the waits that followed
(`spin_policy`: an answer on another socket within the limit teaches a spin; a stream, a
slow sender or an idle endpoint does not), and a duty cap bounds the CPU a spin may take.
This module is the I/O around that policy: the polls and the clock readings.
"""

from __future__ import annotations

import os
import selectors
import time
from typing import TYPE_CHECKING

from simbridge.endpoint.speed.spin_policy import SpinPolicy
from simbridge.errors import EndpointError

if TYPE_CHECKING:
    from _typeshed import FileDescriptorLike

__all__ = ["DEFAULT_DUTY", "MAX_BUSY_POLL_US", "BusyPollSelector"]

MAX_BUSY_POLL_US = 100_000
"""The longest spin accepted (0.1 s); longer only burns CPU."""

DEFAULT_DUTY = 0.5
"""Spinning may take at most this share of wall time (half a core)."""

Ready = list[tuple[selectors.SelectorKey, int]]


def _reads(ready: Ready) -> tuple[int, ...]:
    return tuple(key.fd for key, events in ready if events & selectors.EVENT_READ)


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
        self.policy = SpinPolicy(self.limit, duty, time.perf_counter())
        self.polls = 0
        self.hits = 0
        self.misses = 0
        self.spin_seconds = 0.0

    def window(self, fileobj: FileDescriptorLike) -> float:
        """The spin (seconds) the wait after events on `fileobj` alone starts with."""
        return self.policy.window(self.get_key(fileobj).fd)

    def unregister(self, fileobj: FileDescriptorLike) -> selectors.SelectorKey:
        key = super().unregister(fileobj)
        self.policy.forget(key.fd)
        return key

    def select(self, timeout: float | None = None) -> Ready:
        policy = self.policy
        if timeout is not None and timeout <= 0:  # asyncio has callbacks ready: just look
            ready = super().select(0)
            if ready:
                policy.found(_reads(ready))
            return ready
        after = policy.spin_after()
        if after is None:  # idle, or busy on several: just wait
            ready = super().select(timeout)
            if ready:
                policy.found(_reads(ready))
            else:
                policy.idle()
            return ready
        start = time.perf_counter()
        length = policy.spin_length(after, start, timeout)
        if length:
            ready, end = self._spin(start, length)
            self.spin_seconds += end - start
            answered = policy.found(_reads(ready)) if ready else None
            if policy.spun(after, length, end - start, answered):
                self.misses += 1
            if ready:
                self.hits += 1
                return ready
            if timeout is not None:
                timeout = max(0.0, timeout - (time.perf_counter() - start))
        ready = super().select(timeout)
        gap = time.perf_counter() - start  # from the end of the work to this event
        policy.waited(after, gap, policy.found(_reads(ready)) if ready else None)
        if not ready:
            policy.idle()
        return ready

    def _spin(self, start: float, length: float) -> tuple[Ready, float]:
        """Poll until an event or `length` s from `start`; what came, and when it ended."""
        now, end, poll = start, start + length, super().select
        ready: Ready = []
        while now < end:
            ready = poll(0)
            self.polls += 1
            now = time.perf_counter()
            if ready:
                break
            os.sched_yield()  # another task runnable on this CPU goes first
            now = time.perf_counter()
        return ready, now
