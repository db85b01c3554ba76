"""What runs around a world's steps: trajectory followers before each physics step, step
callbacks after it (every step or at a rate in sim time, wrapped in the callback scopes),
reset callbacks after a reset. Each registration returns a `CallbackHandle` whose
`remove()` takes it out again, so a closed controller or publisher leaves nothing behind.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Generic, TypeVar

from simbridge.errors import SimError
from simbridge.sim.control.follower import TrajectoryFollower
from simbridge.sim.sensors.schedule import RateSchedule
from simbridge.sim.world.scopes import CallbackScopes

__all__ = ["CallbackHandle", "StepCallbacks"]

W = TypeVar("W")
"""The world the callbacks are called with."""

_NEVER = 2**62
"""A step no run reaches (no scheduled callback is waiting)."""


class CallbackHandle:
    """A registered callback, scope or follower; `remove()` takes it out (once: later
    calls do nothing)."""

    __slots__ = ("_remove",)

    def __init__(self, remove: Callable[[], object]) -> None:
        self._remove: Callable[[], object] | None = remove

    @property
    def registered(self) -> bool:
        """Whether `remove` has not been called yet."""
        return self._remove is not None

    def remove(self) -> None:
        """Stop calling it (or using it, for a scope or follower)."""
        remove, self._remove = self._remove, None
        if remove is not None:
            remove()


@dataclass
class _Callback(Generic[W]):
    fn: Callable[[W], None]
    schedule: RateSchedule | None


class StepCallbacks(Generic[W]):
    """The followers, step callbacks, reset callbacks and scopes of one world."""

    def __init__(self, window: float) -> None:
        self.followers: list[TrajectoryFollower] = []
        """Updated before every physics step, in the order added."""
        self.scopes = CallbackScopes(window)
        self._step: dict[int, _Callback[W]] = {}
        self._reset: dict[int, Callable[[W], None]] = {}
        self._next_id = 0
        self._next_due = 0
        """No callback is due before this step (at `_due_timestep`): `run_due` skips the
        callback loop until then. 0 forces a check (after callbacks or the timestep change)."""
        self._due_timestep = 0.0

    def _key(self) -> int:
        self._next_id += 1
        return self._next_id

    def add_follower(self, follower: TrajectoryFollower) -> CallbackHandle:
        """Update `follower` before every physics step (and cancel it at every reset)."""
        self.followers.append(follower)
        return CallbackHandle(lambda: self.followers.remove(follower))

    def add_step(
        self, fn: Callable[[W], None], period: float | None, step: int, timestep: float
    ) -> CallbackHandle:
        """Call `fn` after every step, or at t = k * `period` of sim time from now (`step`
        steps of `timestep` since the reset)."""
        schedule = None
        if period is not None:
            if not (period > 0 and math.isfinite(period)):
                raise SimError(f"callback period must be > 0 seconds, got {period}")
            schedule = RateSchedule(1.0 / period)
            schedule.skip_through(step, timestep)
        key = self._key()
        self._step[key] = _Callback(fn, schedule)
        self._next_due = 0
        return CallbackHandle(lambda: self._step.pop(key, None))

    def add_reset(self, fn: Callable[[W], None]) -> CallbackHandle:
        """Call `fn` after every reset."""
        key = self._key()
        self._reset[key] = fn
        return CallbackHandle(lambda: self._reset.pop(key, None))

    def add_scope(self, scope: AbstractContextManager[object]) -> CallbackHandle:
        """Wrap the step callbacks in `scope` (see `CallbackScopes`)."""
        key = self._key()
        self.scopes.add(key, scope)
        return CallbackHandle(lambda: self.scopes.remove(key))

    def run_due(self, world: W, step: int, timestep: float) -> None:
        """Call the callbacks due at `step` (the scopes entered before the first due one),
        then note the next step any can be due; returns at once before that step."""
        if step < self._next_due and timestep == self._due_timestep:
            return
        self._next_due = -1
        nearest = _NEVER
        scopes = self.scopes
        try:
            for cb in list(self._step.values()):
                schedule = cb.schedule
                if schedule is None or schedule.due(step, timestep):
                    if not scopes.open:
                        scopes.enter()
                    cb.fn(world)
                if schedule is None:
                    nearest = step + 1
                else:
                    nearest = min(nearest, schedule.next_step(timestep))
        except BaseException:
            scopes.close()
            raise
        if self._next_due == -1:  # else a callback added one or reset: check next step
            self._next_due = nearest
            self._due_timestep = timestep

    def after_reset(self, world: W, timestep: float) -> None:
        """Time is 0 again: cancel the followers, restart the schedules, call the reset
        callbacks."""
        for follower in self.followers:
            follower.cancel()
        for cb in self._step.values():
            if cb.schedule is not None:
                cb.schedule.reset()
                cb.schedule.skip_through(0, timestep)
        self._next_due = 0
        for fn in list(self._reset.values()):
            fn(world)
