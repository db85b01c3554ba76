"""Lookup tables tying one robot's URDF names to ids in the compiled MuJoCo model."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco

from simbridge.sim.scene.builder import BuiltRobot
from simbridge.sim.urdf.robot import Joint, JointType, Robot

__all__ = ["JointSlot", "RobotHandle"]


@dataclass(frozen=True)
class JointSlot:
    """Where a 1-DoF joint lives in qpos/qvel and who it follows (if it mimics)."""

    name: str
    qpos: int
    dof: int
    joint: Joint


class RobotHandle:
    """One robot in a `World`: names as in the URDF (plus the scene's prefix), model ids."""

    def __init__(self, built: BuiltRobot, model: mujoco.MjModel) -> None:
        self.name = built.name
        self.built = built
        self.robot: Robot = built.mjcf.robot
        self.prefix = built.spec.prefix
        self.joints: dict[str, JointSlot] = {}
        for joint in self.robot.movable_joints:
            mj_name = built.mjcf.joint_name(joint.name)
            jnt = model.joint(mj_name)
            self.joints[mj_name] = JointSlot(
                mj_name, int(jnt.qposadr[0]), int(jnt.dofadr[0]), joint
            )
        self.bodies: dict[str, int] = {
            built.mjcf.body_name(link): model.body(built.mjcf.body_name(link)).id
            for link in self.robot.links
        }

    @property
    def joint_names(self) -> list[str]:
        """1-DoF joint names (what /joint_states carries), in URDF order."""
        return list(self.joints)

    @property
    def driven_joints(self) -> list[str]:
        """Joint names that have drives (1-DoF, not mimicking another joint)."""
        return list(self.built.drives)

    def mimic_of(self, name: str) -> tuple[str, float, float] | None:
        """(leader joint name, multiplier, offset) if joint `name` mimics another."""
        mimic = self.joints[name].joint.mimic
        if mimic is None:
            return None
        return self.prefix + mimic.joint, mimic.multiplier, mimic.offset

    def tree_edges(self) -> list[tuple[str, str, bool]]:
        """(parent frame, child frame, is_fixed) for every URDF joint, with the prefix."""
        return [
            (self.prefix + j.parent, self.prefix + j.child, j.type is JointType.FIXED)
            for j in self.robot.joints.values()
        ]
