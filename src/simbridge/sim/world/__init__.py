"""The simulation world: build a scene, step it, read state, drive joints, run in real time."""

from __future__ import annotations

from simbridge.sim.world.callbacks import CallbackHandle
from simbridge.sim.world.crossthread import CrossThreadControl
from simbridge.sim.world.pacer import Pacer
from simbridge.sim.world.robot import JointSlot, RobotHandle
from simbridge.sim.world.state import WorldState
from simbridge.sim.world.world import ModelExtension, RunStats, StepCallback, World

__all__ = [
    "CallbackHandle",
    "CrossThreadControl",
    "JointSlot",
    "ModelExtension",
    "Pacer",
    "RobotHandle",
    "RunStats",
    "StepCallback",
    "World",
    "WorldState",
]
