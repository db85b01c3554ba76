"""Fixed-rate scheduling in simulated time."""

from __future__ import annotations

import math

from simbridge.errors import SimError

__all__ = ["RateSchedule"]

# Slack for floating-point accumulation of the simulation clock (far below any timestep).
_TIME_EPS = 1e-9


class RateSchedule:
    """Fires at t = k / rate (k = 0, 1, ...) of simulated time, so a 10 Hz sensor fires
    exactly 10 times per simulated second; ticks that fall inside one step fire once."""

    def __init__(self, rate_hz: float) -> None:
        if not (math.isfinite(rate_hz) and rate_hz > 0):
            raise SimError(f"sensor rate must be a positive number of Hz, got {rate_hz!r}")
        self.rate_hz = rate_hz
        self._next_tick = 0

    @property
    def period(self) -> float:
        """Seconds of simulated time between two readings."""
        return 1.0 / self.rate_hz

    def due(self, sim_time: float) -> bool:
        """True once per tick reached by `sim_time`; advances past every tick reached."""
        if sim_time + _TIME_EPS < self._next_tick / self.rate_hz:
            return False
        self._next_tick = math.floor(sim_time * self.rate_hz + _TIME_EPS) + 1
        return True

    def reset(self) -> None:
        """Start over (after a simulation reset to t = 0)."""
        self._next_tick = 0
