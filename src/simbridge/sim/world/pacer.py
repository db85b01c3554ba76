"""Keep simulated time in step with wall-clock time at a given real-time factor."""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ["Pacer"]


class Pacer:
    """Sleeps so that sim time advances `factor` times as fast as wall time (0: no pacing)."""

    def __init__(self, factor: float, min_sleep: float = 0.001) -> None:
        self.factor = factor
        self.min_sleep = min_sleep
        self._wall0 = time.perf_counter()
        self._sim0 = 0.0

    def restart(self, sim_time: float) -> None:
        """Take `sim_time` as the new anchor (after a pause or reset)."""
        self._wall0 = time.perf_counter()
        self._sim0 = sim_time

    def wait(self, sim_time: float, before_sleep: Callable[[], None] | None = None) -> None:
        """Sleep until wall time catches up with `sim_time` (only when it is ahead by
        more than `min_sleep`, so fast steps are batched into one sleep), calling
        `before_sleep` first (e.g. to send what is waiting)."""
        if self.factor <= 0:
            return
        due = self._wall0 + (sim_time - self._sim0) / self.factor
        ahead = due - time.perf_counter()
        if ahead > self.min_sleep:
            if before_sleep is not None:
                before_sleep()
                ahead = due - time.perf_counter()
            time.sleep(max(ahead, 0.0))
