"""How long a busy poll should spin: the learning behind `BusyPollSelector`, with no I/O
and no clock of its own (times come in as arguments), so its rules are tested as arithmetic.

A spin after reading from one socket is learned from the waits that followed: an answer
(data on another socket) within the limit sets it to twice that wait; a wait past the limit,
a spin that found nothing, or one that found the same socket again (a stream) shrinks it. A
duty cap allows `duty` seconds of spin per second of wall time, saved up to `BURST`.
"""

from __future__ import annotations

import math

__all__ = ["BURST", "SHORTEST", "SpinPolicy"]

BURST = 0.02
"""Unspent spin allowance saved up, in seconds: a quiet spell buys at most this much."""

SHORTEST = 5e-6
"""A spin shrunk below this (seconds) is off until a short wait shows it would pay again."""


class SpinPolicy:
    """Learned spins per file descriptor, the duty allowance, and which descriptors the
    last events came from (an answer comes from another one)."""

    def __init__(self, limit: float, duty: float, now: float) -> None:
        self.limit, self.duty = limit, duty
        self._windows: dict[int, float] = {}
        self._busy = False
        self._last: tuple[int, ...] = ()
        self._allowance = BURST
        self._refilled = now

    def window(self, fd: int) -> float:
        """The spin (seconds) the wait after events on `fd` alone starts with."""
        return self._windows.get(fd, 0.0)

    def forget(self, fd: int) -> None:
        """`fd` left the selector: what was learned for it goes too."""
        self._windows.pop(fd, None)

    def spin_after(self) -> int | None:
        """The descriptor whose events alone the next wait follows, or None when there is
        nothing to spin for (the last wait found nothing, or events on several)."""
        return self._last[0] if self._busy and len(self._last) == 1 else None

    def found(self, reads: tuple[int, ...]) -> bool:
        """Events came (`reads`: the descriptors with data to read); whether they answer what
        the last ones brought (other descriptors), not a stream. Room to write is no answer."""
        self._busy = True
        if not reads:
            return False
        answered = all(fd not in self._last for fd in reads)
        self._last = reads
        return answered

    def idle(self) -> None:
        """A wait found nothing: the next one just sleeps."""
        self._busy = False

    def spin_length(self, after: int, now: float, timeout: float | None) -> float:
        """Seconds to spin at `now` after events on `after`: its window, cut to the saved-up
        allowance (0 when an overlong spin overdrew it) and to asyncio's `timeout`; 0 when
        nothing was learned."""
        window = self.window(after)
        if not window:
            return 0.0
        self._allowance = min(BURST, self._allowance + (now - self._refilled) * self.duty)
        self._refilled = now
        return max(0.0, min(window, self._allowance, math.inf if timeout is None else timeout))

    def spun(self, after: int, length: float, spent: float, answered: bool | None) -> bool:
        """A spin of `length` took `spent` s and found an answer (True), the same socket
        again (False) or nothing (None); whether it was a miss (the whole window, empty)."""
        self._allowance -= spent
        miss = answered is None and length == self.window(after)
        if miss or answered is False:
            self._shrink(after)
        return miss

    def waited(self, after: int, gap: float, answered: bool | None) -> None:
        """A blocking wait after events on `after` ended `gap` s after they were handled,
        with an answer (True), the same socket again (False) or nothing (None)."""
        if gap > self.limit:
            self._windows.pop(after, None)
        elif answered:
            self._windows[after] = min(self.limit, max(self.window(after), 2 * gap))

    def _shrink(self, after: int) -> None:
        half = self.window(after) / 2
        if half >= SHORTEST:
            self._windows[after] = half
        else:
            self._windows.pop(after, None)
