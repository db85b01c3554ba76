"""Poses and rotations for the planner: ROS conventions (metres, quaternions as x, y, z, w)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = [
    "FloatArray",
    "Pose",
    "matrix_to_quaternion",
    "quaternion_to_matrix",
    "rotation_error",
    "top_down_orientation",
]

FloatArray = npt.NDArray[np.float64]


def quaternion_to_matrix(quat_xyzw: npt.ArrayLike) -> FloatArray:
    """Rotation matrix of a (not necessarily unit) quaternion given as x, y, z, w."""
    x, y, z, w = np.asarray(quat_xyzw, dtype=np.float64)
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if norm < 1e-12:
        raise ValueError(f"quaternion {quat_xyzw!r} has zero norm")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quaternion(rotation: npt.ArrayLike) -> FloatArray:
    """Unit quaternion (x, y, z, w, with w >= 0) of a rotation matrix."""
    r = np.asarray(rotation, dtype=np.float64)
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = [(r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s, s / 4]
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
        q = [s / 4, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s, (r[2, 1] - r[1, 2]) / s]
    elif r[1, 1] > r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
        q = [(r[0, 1] + r[1, 0]) / s, s / 4, (r[1, 2] + r[2, 1]) / s, (r[0, 2] - r[2, 0]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
        q = [(r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, s / 4, (r[1, 0] - r[0, 1]) / s]
    quat = np.array(q)
    quat /= np.linalg.norm(quat)
    return -quat if quat[3] < 0 else quat


def rotation_error(current: FloatArray, goal: FloatArray) -> FloatArray:
    """Rotation vector (axis * angle, world frame) turning ``current`` into ``goal``."""
    delta = goal @ current.T
    cos_angle = np.clip((np.trace(delta) - 1.0) / 2.0, -1.0, 1.0)
    angle = math.acos(cos_angle)
    axis = np.array(
        [delta[2, 1] - delta[1, 2], delta[0, 2] - delta[2, 0], delta[1, 0] - delta[0, 1]]
    )
    sin_angle = math.sin(angle)
    if sin_angle > 1e-6:
        return np.asarray(axis * (angle / (2.0 * sin_angle)))
    if cos_angle > 0:  # tiny angle: first-order expansion
        return np.asarray(axis / 2.0)
    # angle ~ pi: axis from the symmetric part
    sym = (delta + np.eye(3)) / 2.0
    col = int(np.argmax(np.diag(sym)))
    unit = sym[:, col] / math.sqrt(max(sym[col, col], 1e-12))
    return np.asarray(unit * angle)


def top_down_orientation(yaw: float = 0.0) -> FloatArray:
    """Quaternion (x, y, z, w) pointing a tool's x (approach) axis straight down, turned by yaw.

    This is the tutorial's grasp orientation: Unity's Euler(90, yaw, 0) seen in ROS axes
    is a +90 degree pitch about y followed by a yaw about the vertical.
    """
    pitch = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    c, s = math.cos(yaw), math.sin(yaw)
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return matrix_to_quaternion(turn @ pitch)


def _vector3(values: npt.ArrayLike) -> FloatArray:
    array = np.array(values, dtype=np.float64).reshape(-1)
    if array.shape != (3,) or not np.all(np.isfinite(array)):
        raise ValueError(f"position must be 3 finite numbers, got {values!r}")
    return array


def _quaternion(values: npt.ArrayLike) -> FloatArray:
    array = np.array(values, dtype=np.float64).reshape(-1)
    norm = float(np.linalg.norm(array)) if array.shape == (4,) else 0.0
    if not np.isfinite(norm) or norm < 1e-9:
        raise ValueError(f"orientation must be a non-zero quaternion (x, y, z, w), got {values!r}")
    return np.asarray(array / norm)


@dataclass(frozen=True, init=False)
class Pose:
    """A frame's position (m) and orientation (unit quaternion x, y, z, w) in a reference frame."""

    position: FloatArray
    orientation: FloatArray

    def __init__(
        self,
        position: npt.ArrayLike = (0.0, 0.0, 0.0),
        orientation: npt.ArrayLike = (0.0, 0.0, 0.0, 1.0),
    ) -> None:
        object.__setattr__(self, "position", _vector3(position))
        object.__setattr__(self, "orientation", _quaternion(orientation))

    @classmethod
    def from_matrix(cls, position: npt.ArrayLike, rotation: npt.ArrayLike) -> Pose:
        """Build a pose from a position and a 3x3 rotation matrix."""
        return cls(np.asarray(position, dtype=np.float64), matrix_to_quaternion(rotation))

    @property
    def rotation(self) -> FloatArray:
        """The orientation as a 3x3 rotation matrix."""
        return quaternion_to_matrix(self.orientation)

    def translated(self, dx: float = 0.0, dy: float = 0.0, dz: float = 0.0) -> Pose:
        """The same orientation at a position shifted in the reference frame."""
        return Pose(self.position + np.array([dx, dy, dz]), self.orientation)

    def describe(self) -> str:
        """Short human-readable form used in error messages."""
        x, y, z = self.position
        qx, qy, qz, qw = self.orientation
        return f"(x={x:.3f}, y={y:.3f}, z={z:.3f}; q=[{qx:.3f}, {qy:.3f}, {qz:.3f}, {qw:.3f}])"
