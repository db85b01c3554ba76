"""RateSchedule: ticks on whole physics steps, exact over hours of simulated time."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.errors import SimError
from simbridge.sim.sensors import RateSchedule
from simbridge.sim.sensors.schedule import as_fraction, step_index


def test_ticks_fall_on_the_first_step_reaching_them():
    schedule = RateSchedule(10.0)
    dt = 0.003  # does not divide the period: ticks at ceil(k * 0.1 / 0.003) steps
    fired = [step for step in range(334) if schedule.due(step, dt)]
    assert fired == [math.ceil(Fraction(k, 10) / Fraction(3, 1000)) for k in range(10)]
    assert fired[:4] == [0, 34, 67, 100]


def test_a_late_poll_fires_once_and_the_schedule_stays_on_its_grid():
    schedule = RateSchedule(100.0)  # every 5 steps of 2 ms
    assert schedule.due(0, 0.002)
    assert schedule.due(23, 0.002)  # ticks at 5..20 missed: one firing, not four
    assert not schedule.due(24, 0.002)
    assert schedule.due(25, 0.002)
    schedule.reset()
    assert schedule.due(0, 0.002)


def test_faster_than_the_physics_fires_every_step():
    schedule = RateSchedule(1000.0)
    assert all(schedule.due(step, 0.002) for step in range(100))


def test_bad_rates_and_timesteps_are_refused():
    for rate in (0.0, -1.0, math.inf, math.nan, 1e-9):
        with pytest.raises(SimError, match="rate"):
            RateSchedule(rate)
    with pytest.raises(SimError, match="timestep must be a positive number"):
        RateSchedule(10.0).due(1, 0.0)


def test_decimal_settings_are_exact_fractions():
    assert as_fraction(0.002) == Fraction(1, 500)
    assert as_fraction(1 / 240) == Fraction(1, 240)
    assert as_fraction(29.97) == Fraction(2997, 100)


@settings(max_examples=80, deadline=None)
@given(
    rate=st.sampled_from([0.5, 1.0, 7.0, 10.0, 29.97, 30.0, 50.0, 100.0, 200.0, 333.0]),
    dt=st.sampled_from([0.0005, 0.001, 0.002, 0.003, 1 / 240, 0.005, 0.01]),
    steps=st.integers(1, 5000),
)
def test_fires_once_per_tick_reached(rate, dt, steps):
    schedule = RateSchedule(rate)
    fired = [n for n in range(steps) if schedule.due(n, dt)]
    steps_per_tick = 1 / (as_fraction(rate) * as_fraction(dt))
    if steps_per_tick >= 1:
        # ticks k with k * steps_per_tick <= last step, each on its own step
        assert len(fired) == math.floor((steps - 1) / steps_per_tick) + 1
        gaps = set(np.diff(fired).tolist())
        assert gaps <= {math.floor(steps_per_tick), math.ceil(steps_per_tick)}
    else:
        assert fired == list(range(steps))


def test_rates_stay_exact_over_two_hours_of_a_summed_clock():
    """The clock is summed step by step as MuJoCo does (time += timestep): a 100 Hz
    schedule fed with it used to fire 145-150 times per second after a minute."""
    dt, hours = 0.002, 2
    steps = int(hours * 3600 / dt)
    clock = np.cumsum(np.full(steps, dt))  # sequential float additions, like mj_step
    drift = np.abs(clock - np.arange(1, steps + 1) * dt).max()
    assert drift > 1e-9  # the summed clock really drifts (so float comparisons fail)
    assert [step_index(float(t), dt) for t in clock[-1000:]] == list(range(steps - 999, steps + 1))
    indices = np.rint(clock / dt).astype(int).tolist()  # step_index, vectorised
    assert indices == list(range(1, steps + 1))
    rates = (100.0, 30.0)
    schedules = [RateSchedule(rate) for rate in rates]
    fired: list[list[int]] = [[] for _ in rates]
    for n in indices:
        for schedule, out in zip(schedules, fired, strict=True):
            if schedule.due(n, dt):
                out.append(n)
    per_second = round(1 / dt)
    for rate, out in zip(rates, fired, strict=True):
        counts = np.bincount(np.array(out) // per_second)[: hours * 3600]
        # every simulated second of the two hours holds exactly `rate` readings
        assert set(counts.tolist()) == {int(rate)}, rate
        assert len(set(out)) == len(out)
