"""Fixed-rate scheduling in simulated time, counted in whole physics steps.

Floating-point clocks drift: a 100 Hz schedule compared against a clock summed step by
step fired 145-150 times per simulated second after a minute. Here every tick is placed
on an integer step with exact rational arithmetic, so rates stay exact for any run length.
"""

from __future__ import annotations

import math
from fractions import Fraction

from simbridge.errors import SimError

__all__ = ["RateSchedule", "as_fraction", "step_index"]

# Rates and timesteps are read as the nearest fraction with a denominator up to this
# (0.002 s is 1/500 s, 30 Hz is 30/1), so decimal settings are exact.
_MAX_DENOMINATOR = 1_000_000


def as_fraction(value: float) -> Fraction:
    """`value` as the nearest fraction with a denominator of at most 10^6."""
    return Fraction(value).limit_denominator(_MAX_DENOMINATOR)


def step_index(sim_time: float, timestep: float) -> int:
    """The physics step a clock reading belongs to (robust to summed rounding error,
    which stays far below half a step for years of simulated time)."""
    return round(sim_time / timestep)


class RateSchedule:
    """Fires once per tick k = 0, 1, ... at the first step n with n * timestep >= k / rate.

    A 10 Hz schedule thus fires exactly 10 times per simulated second; ticks that fall
    inside one step fire once (a schedule faster than the physics runs at the step rate).
    """

    def __init__(self, rate_hz: float) -> None:
        if not (math.isfinite(rate_hz) and rate_hz > 0):
            raise SimError(f"rate must be a positive number of Hz, got {rate_hz!r}")
        self.rate_hz = rate_hz
        self._rate = as_fraction(rate_hz)
        if self._rate == 0:
            raise SimError(f"rate {rate_hz!r} Hz is below the schedule's resolution (1e-6 Hz)")
        self._timestep: float | None = None
        self._num = self._den = 1  # steps per tick = _num / _den, for `_timestep`
        self._next_tick = 0
        self._next_step = 0

    @property
    def period(self) -> float:
        """Seconds of simulated time between two ticks."""
        return 1.0 / self.rate_hz

    def _use_timestep(self, timestep: float) -> None:
        if timestep == self._timestep:
            return
        if not (math.isfinite(timestep) and timestep > 0):
            raise SimError(f"timestep must be a positive number of seconds, got {timestep!r}")
        steps_per_tick = 1 / (self._rate * as_fraction(timestep))
        self._timestep = timestep
        self._num, self._den = steps_per_tick.numerator, steps_per_tick.denominator
        self._next_step = self._step_of_tick(self._next_tick)

    def _step_of_tick(self, tick: int) -> int:
        return -(-tick * self._num // self._den)  # ceil(tick * steps_per_tick)

    def next_step(self, timestep: float) -> int:
        """The first step at which `due(step, timestep)` is True (a caller may skip
        polling until then)."""
        if timestep != self._timestep:
            self._use_timestep(timestep)
        return self._next_step

    def due(self, step: int, timestep: float) -> bool:
        """True once per tick reached by physics step `step`; advances past every tick
        reached (so a late or skipped poll fires once, not once per missed tick)."""
        if timestep != self._timestep:
            self._use_timestep(timestep)
        if step < self._next_step:
            return False
        self._advance(step)
        return True

    def skip_through(self, step: int, timestep: float) -> None:
        """Mark every tick reached by `step` as done (the next fires after it)."""
        if timestep != self._timestep:
            self._use_timestep(timestep)
        self._advance(step)

    def _advance(self, step: int) -> None:
        self._next_tick = max(self._next_tick, step * self._den // self._num + 1)
        self._next_step = self._step_of_tick(self._next_tick)

    def reset(self) -> None:
        """Start over (after a simulation reset to step 0)."""
        self._next_tick = 0
        self._next_step = 0
