"""Runs a sensor suite inside a simulation loop: polled after every physics step."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any, Protocol

import mujoco

from simbridge.sim.sensors.rosmsg import Publication
from simbridge.sim.sensors.suite import SensorSuite

__all__ = ["SteppedWorld", "attach_sensors"]


class SteppedWorld(Protocol):
    """What the sensors need from a world: its model and data, a per-step hook and a
    refresh of derived quantities after a step (`simbridge.sim.world.World` fits)."""

    model: mujoco.MjModel
    data: mujoco.MjData

    def refresh(self) -> None:
        """Bring derived quantities (poses, velocities) up to the current state."""
        ...

    def add_step_callback(self, fn: Callable[[Any], None], period: float | None = None) -> object:
        """Call `fn(world)` after every step (what it returns takes the callback out)."""
        ...


def attach_sensors(
    world: SteppedWorld,
    configs: Sequence[Mapping[str, Any]],
    publish: Callable[[Publication], None],
) -> SensorSuite:
    """Build the sensors listed in a scene's `sensors:` entries on `world.model` and hand
    every due message to `publish` after each step (on the simulation thread).

    The returned suite takes `set_wanted(topic, flag)` for laziness and gives
    `static_transforms(model)` for /tf_static; `close()` it when the world is done.
    """
    suite = SensorSuite.from_config(world.model, configs)

    def on_step(stepped: SteppedWorld) -> None:
        for publication in suite.poll(stepped.model, stepped.data, stepped.refresh):
            publish(publication)

    world.add_step_callback(on_step)
    return suite
