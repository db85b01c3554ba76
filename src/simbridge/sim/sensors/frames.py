"""Sensor mounts: a body plus a fixed local offset, resolved to a world pose each step."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import SimError, did_you_mean
from simbridge.sim.urdf.transforms import rpy_to_matrix

__all__ = ["Mount", "MountedFrame", "Pose", "quat_wxyz_from_matrix"]

Vec3 = tuple[float, float, float]
FloatArray = NDArray[np.float64]

WORLD_BODY_NAMES = ("", "world")


def quat_wxyz_from_matrix(rotation: FloatArray) -> FloatArray:
    """Unit quaternion (w, x, y, z) of a rotation matrix, with w >= 0."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=np.float64).ravel())
    return quat if quat[0] >= 0 else -quat


@dataclass(frozen=True)
class Pose:
    """A rigid transform: position and rotation matrix (columns are the frame's axes)."""

    position: FloatArray
    rotation: FloatArray

    def compose(self, other: Pose) -> Pose:
        """This pose followed by `other` expressed in this pose's frame."""
        return Pose(self.position + self.rotation @ other.position, self.rotation @ other.rotation)

    def inverse(self) -> Pose:
        """The transform mapping this frame's parent into this frame."""
        rot_t = self.rotation.T
        return Pose(-rot_t @ self.position, rot_t)

    def quat_wxyz(self) -> FloatArray:
        """Orientation as a unit quaternion (w, x, y, z)."""
        return quat_wxyz_from_matrix(self.rotation)


@dataclass(frozen=True)
class Mount:
    """Where a sensor sits: a MuJoCo body (a URDF link) and an offset in that body's frame.

    `body` "" or "world" mounts on the world body. The offset uses URDF conventions
    (xyz in metres, rpy in radians) and ROS body axes (x forward, y left, z up).
    """

    body: str
    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)

    def offset(self) -> Pose:
        """The sensor frame relative to the body frame."""
        return Pose(np.array(self.xyz, dtype=np.float64), rpy_to_matrix(self.rpy))

    def resolve(self, model: mujoco.MjModel) -> MountedFrame:
        """Bind this mount to a compiled model; raises SimError for an unknown body."""
        if self.body in WORLD_BODY_NAMES:
            return MountedFrame(0, self.offset())
        body_id = int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, self.body))
        if body_id < 0:
            names = [model.body(i).name for i in range(model.nbody)]
            raise SimError(
                f"sensor mount body {self.body!r} is not in the model"
                f"{did_you_mean(self.body, names)} (bodies: {', '.join(names[1:])}, world)"
            )
        return MountedFrame(body_id, self.offset())


@dataclass(frozen=True)
class MountedFrame:
    """A mount bound to a model: body id and the sensor's offset in that body."""

    body_id: int
    offset: Pose

    def world_pose(self, data: mujoco.MjData) -> Pose:
        """The sensor frame in world coordinates for the current kinematics in `data`."""
        body = Pose(
            np.array(data.xpos[self.body_id]), np.array(data.xmat[self.body_id]).reshape(3, 3)
        )
        return body.compose(self.offset)
