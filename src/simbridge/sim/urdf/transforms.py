"""Rigid transforms in ROS conventions (REP 103): RPY is fixed-axis X, then Y, then Z."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "Transform",
    "axis_angle_matrix",
    "matrix_to_quat_wxyz",
    "quat_wxyz_to_matrix",
    "rpy_to_matrix",
]

Vec3 = tuple[float, float, float]
Matrix = NDArray[np.float64]


def rpy_to_matrix(rpy: Vec3) -> Matrix:
    """Rotation matrix for URDF roll/pitch/yaw: R = Rz(yaw) @ Ry(pitch) @ Rx(roll)."""
    roll, pitch, yaw = rpy
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ],
        dtype=np.float64,
    )


def axis_angle_matrix(axis: Vec3 | Matrix, angle: float) -> Matrix:
    """Rotation by `angle` radians about the unit vector `axis` (Rodrigues' formula)."""
    x, y, z = (float(v) for v in axis)
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return np.array(
        [
            [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
            [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
            [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
        ],
        dtype=np.float64,
    )


def matrix_to_quat_wxyz(rot: Matrix) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) with w >= 0 for a rotation matrix (Shepperd's method)."""
    m = rot
    trace = float(m[0, 0] + m[1, 1] + m[2, 2])
    if trace > 0.0:
        s = math.sqrt(trace + 1.0) * 2.0
        q = (0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s)
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2.0
        q = ((m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s)
    elif m[1, 1] > m[2, 2]:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2.0
        q = ((m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s)
    else:
        s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2.0
        q = ((m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s)
    arr = np.array(q, dtype=np.float64)
    arr /= np.linalg.norm(arr)
    if arr[0] < 0.0:
        arr = -arr
    return (float(arr[0]), float(arr[1]), float(arr[2]), float(arr[3]))


def quat_wxyz_to_matrix(quat: tuple[float, float, float, float] | Matrix) -> Matrix:
    """Rotation matrix of a (w, x, y, z) quaternion; the quaternion is normalised first."""
    w, x, y, z = (float(v) for v in quat)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if n == 0.0:
        raise ValueError("zero quaternion has no rotation")
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ],
        dtype=np.float64,
    )


@dataclass(frozen=True)
class Transform:
    """A rigid transform: rotate by `rotation`, then translate by `translation`."""

    rotation: Matrix
    translation: Matrix

    @staticmethod
    def identity() -> Transform:
        """The transform that changes nothing."""
        return Transform(np.eye(3), np.zeros(3))

    @staticmethod
    def from_xyz_rpy(xyz: Vec3, rpy: Vec3) -> Transform:
        """Transform of a URDF `<origin xyz rpy>`."""
        return Transform(rpy_to_matrix(rpy), np.array(xyz, dtype=np.float64))

    @staticmethod
    def from_xyz_quat_wxyz(
        xyz: Vec3 | Matrix, quat: tuple[float, float, float, float] | Matrix
    ) -> Transform:
        """Transform from a position and a (w, x, y, z) quaternion."""
        return Transform(quat_wxyz_to_matrix(quat), np.array(xyz, dtype=np.float64))

    def __matmul__(self, other: Transform) -> Transform:
        """Compose: (self @ other) applies `other` first, then `self`."""
        return Transform(
            self.rotation @ other.rotation, self.rotation @ other.translation + self.translation
        )

    def inverse(self) -> Transform:
        """The transform that undoes this one."""
        rt = self.rotation.T
        return Transform(rt, -(rt @ self.translation))

    def apply(self, point: Matrix) -> Matrix:
        """Map a point from the child frame into the parent frame."""
        return np.asarray(self.rotation @ point + self.translation, dtype=np.float64)

    @property
    def quat_wxyz(self) -> tuple[float, float, float, float]:
        """Orientation as a (w, x, y, z) quaternion with w >= 0."""
        return matrix_to_quat_wxyz(self.rotation)

    @property
    def quat_xyzw(self) -> tuple[float, float, float, float]:
        """Orientation as a ROS (x, y, z, w) quaternion with w >= 0."""
        w, x, y, z = self.quat_wxyz
        return (x, y, z, w)

    @property
    def xyz(self) -> tuple[float, float, float]:
        """Translation as a plain tuple."""
        return (float(self.translation[0]), float(self.translation[1]), float(self.translation[2]))
