"""`type: robot_joints`: robot joint configurations drawn within the joints' limits.

- type: robot_joints
  robot: niryo_one           # default: every robot
  joints: [joint_1, joint_2] # default: every driven joint (mimic joints follow)
  range: 1.0                 # share of each joint's limit range used, about its middle
                             # (joints without limits: [-pi, pi] radians)
"""

from __future__ import annotations

import math

import numpy as np

from simbridge.errors import PerceptionError
from simbridge.perception.randomizers.base import FrameState, Randomizer
from simbridge.perception.section import Section
from simbridge.sim import World

__all__ = ["RobotJointsRandomizer"]


class RobotJointsRandomizer(Randomizer):
    kind = "robot_joints"
    KEYS = ("type", "robot", "joints", "range")

    def __init__(self, section: Section) -> None:
        self.robot = section.string("robot", "") or None
        self.joint_names = section.strings("joints")
        self.share = section.number("range", 1.0, 0.0, 1.0)
        section.done(self.KEYS)
        self.joints: list[tuple[str, float, float]] = []

    def bind(self, world: World) -> None:
        robots = (
            [world.robot(self.robot)] if self.robot is not None else list(world.robots.values())
        )
        driven = {name: robot for robot in robots for name in robot.driven_joints}
        names = list(self.joint_names) or list(driven)
        self.joints = []
        for name in names:
            robot = driven.get(name)
            if robot is None:
                raise PerceptionError(
                    f"joints: '{name}' is not a driven joint "
                    f"(driven: {', '.join(driven) or 'none'})"
                )
            joint = robot.joints[name].joint
            low, high = -math.pi, math.pi
            if joint.limited and joint.limit is not None:
                low, high = joint.limit.lower, joint.limit.upper
            middle, half = (low + high) / 2, (high - low) / 2 * self.share
            self.joints.append((name, middle - half, middle + half))

    def apply(self, state: FrameState, rng: np.random.Generator) -> None:
        values = {name: float(rng.uniform(low, high)) for name, low, high in self.joints}
        state.world.set_joint_positions(values)
