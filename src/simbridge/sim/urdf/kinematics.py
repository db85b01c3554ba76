"""Forward kinematics straight from the URDF (no MuJoCo), in ROS conventions."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from simbridge.errors import UrdfError
from simbridge.sim.urdf.robot import Joint, JointType, Robot
from simbridge.sim.urdf.transforms import Transform, axis_angle_matrix, quat_wxyz_to_matrix

__all__ = ["JointValue", "forward_kinematics", "joint_motion", "plane_basis"]

Vector = NDArray[np.float64]
JointValue = float | Sequence[float]
"""A scalar for 1-DoF joints; (x, y, theta) for planar; (x, y, z, qx, qy, qz, qw) for floating."""


def plane_basis(normal: tuple[float, float, float]) -> tuple[Vector, Vector]:
    """Two unit vectors u, v spanning the plane with normal `normal`, with u x v = normal."""
    n = np.array(normal, dtype=np.float64)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = helper - n * float(helper @ n)
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    return u, v


def _values(joint: Joint, value: JointValue, count: int) -> list[float]:
    values = [float(value)] if isinstance(value, int | float) else [float(v) for v in value]
    if len(values) != count or any(math.isnan(v) for v in values):
        raise UrdfError(
            f"joint '{joint.name}' ({joint.type.value}) takes {count} number(s), got {value!r}"
        )
    return values


def joint_motion(joint: Joint, value: JointValue) -> Transform:
    """The motion of `joint` at `value`, expressed in the joint (child link) frame."""
    jt = joint.type
    if jt is JointType.FIXED:
        return Transform.identity()
    if jt in (JointType.REVOLUTE, JointType.CONTINUOUS):
        (q,) = _values(joint, value, 1)
        return Transform(axis_angle_matrix(joint.axis, q), np.zeros(3))
    if jt is JointType.PRISMATIC:
        (q,) = _values(joint, value, 1)
        return Transform(np.eye(3), np.array(joint.axis) * q)
    if jt is JointType.PLANAR:
        x, y, theta = _values(joint, value, 3)
        u, v = plane_basis(joint.axis)
        return Transform(axis_angle_matrix(joint.axis, theta), x * u + y * v)
    x, y, z, qx, qy, qz, qw = _values(joint, value, 7)
    return Transform(quat_wxyz_to_matrix((qw, qx, qy, qz)), np.array([x, y, z]))


def _zero(joint: Joint) -> JointValue:
    if joint.type is JointType.PLANAR:
        return (0.0, 0.0, 0.0)
    if joint.type is JointType.FLOATING:
        return (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    return 0.0


def forward_kinematics(
    robot: Robot, values: Mapping[str, JointValue] | None = None, base: Transform | None = None
) -> dict[str, Transform]:
    """World pose of every link; unset joints are at zero, mimic joints follow their leader."""
    values = dict(values or {})
    for name in values:
        if name not in robot.joints:
            raise UrdfError(f"unknown joint '{name}' (joints: {', '.join(robot.joints) or 'none'})")
        mimic = robot.joints[name].mimic
        if mimic is not None:
            raise UrdfError(f"joint '{name}' mimics '{mimic.joint}': set '{mimic.joint}' instead")
    poses = {robot.root: base or Transform.identity()}
    for link in robot.links_depth_first()[1:]:
        joint = robot.parent_joint(link)
        assert joint is not None
        if joint.mimic is not None:
            leader = robot.joints[joint.mimic.joint]
            lead = _values(leader, values.get(leader.name, 0.0), 1)[0]
            value: JointValue = joint.mimic.multiplier * lead + joint.mimic.offset
        else:
            value = values.get(joint.name, _zero(joint))
        poses[link] = poses[joint.parent] @ joint.origin.transform @ joint_motion(joint, value)
    return poses
