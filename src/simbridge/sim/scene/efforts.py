"""Effort limits at load: the static gravity torque each joint must hold at the initial pose,
and the scene's policy for URDF efforts that cannot hold it (placeholder values are common)."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from simbridge.errors import SimError
from simbridge.sim.urdf.kinematics import JointValue, forward_kinematics
from simbridge.sim.urdf.robot import Inertial, JointType, Robot
from simbridge.sim.urdf.transforms import Transform, Vec3

__all__ = ["EFFORT_POLICIES", "SCALE_MARGIN", "effort_limits", "gravity_torques"]

EFFORT_POLICIES = ("urdf", "ignore", "scale")
"""urdf: the URDF `effort` is the drive's force limit; ignore: drives are unlimited;
scale: every URDF effort is multiplied by one factor so that each joint holds
`SCALE_MARGIN` times its gravity torque at the initial pose."""
SCALE_MARGIN = 2.0


def gravity_torques(
    robot: Robot,
    inertials: Mapping[str, Inertial | None],
    positions: Mapping[str, JointValue],
    base: Transform,
    gravity: Vec3,
) -> dict[str, float]:
    """|torque| (N m, or N for prismatic joints) each 1-DoF joint needs to hold the links
    below it still against `gravity` at `positions` (base held; mimic coupling ignored)."""
    poses = forward_kinematics(robot, positions, base)
    g = np.asarray(gravity, dtype=np.float64)
    weight: dict[str, tuple[float, np.ndarray]] = {}  # link -> (mass, mass * com) of subtree
    for link in reversed(robot.links_depth_first()):
        inertial = inertials.get(link)
        mass, moment = 0.0, np.zeros(3)
        if inertial is not None:
            mass = inertial.mass
            moment = mass * poses[link].apply(np.asarray(inertial.origin.xyz, dtype=np.float64))
        for joint in robot.child_joints(link):
            sub_mass, sub_moment = weight[joint.child]
            mass, moment = mass + sub_mass, moment + sub_moment
        weight[link] = (mass, moment)
    torques: dict[str, float] = {}
    for joint in robot.movable_joints:
        mass, moment = weight[joint.child]
        frame = poses[joint.child]
        axis = frame.rotation @ np.asarray(joint.axis, dtype=np.float64)
        if joint.type is JointType.PRISMATIC:
            torques[joint.name] = abs(float(mass * g @ axis))
        else:  # sum over links of (c - p) x (m g), about the axis
            lever = moment - mass * frame.translation
            torques[joint.name] = abs(float(np.cross(lever, g) @ axis))
    return torques


def effort_limits(
    policy: str,
    urdf_efforts: Mapping[str, float],
    torques: Mapping[str, float],
) -> tuple[dict[str, float | None], float]:
    """Force limit per joint under `policy` (None: unlimited) and the scale factor used."""
    if policy not in EFFORT_POLICIES:
        raise SimError(f"effort_limits '{policy}' (valid: {', '.join(EFFORT_POLICIES)})")
    if policy == "ignore":
        return dict.fromkeys(urdf_efforts), 1.0
    factor = 1.0
    if policy == "scale":
        needs = [
            SCALE_MARGIN * torques.get(name, 0.0) / effort
            for name, effort in urdf_efforts.items()
            if effort > 0
        ]
        factor = max([1.0, *needs])
    limits: dict[str, float | None] = {
        name: effort * factor if effort > 0 and math.isfinite(effort) else None
        for name, effort in urdf_efforts.items()
    }
    return limits, factor
