"""Dataset cameras: a pinhole model (fx, fy, cx, cy) at a world pose in the REP 103
optical frame (x right, y down, z forward), projection, and the matching OpenGL frustum.

Pixel coordinates follow OpenCV and ROS CameraInfo: the centre of pixel (column i, row j)
is at (u, v) = (i, j), so a centred principal point is ((W - 1) / 2, (H - 1) / 2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import PerceptionError
from simbridge.perception.section import Section

__all__ = ["CameraSpec", "CameraView", "look_at"]

FloatArray = NDArray[np.float64]


def look_at(eye: FloatArray, target: FloatArray, up: FloatArray) -> FloatArray:
    """Rotation (columns: optical x, y, z in world axes) of a camera at `eye` looking at
    `target`, image up towards `up`."""
    forward = target - eye
    norm = float(np.linalg.norm(forward))
    if norm < 1e-9:
        raise PerceptionError(f"camera eye {eye.tolist()} and target coincide")
    z = forward / norm
    x = np.cross(z, up)
    if float(np.linalg.norm(x)) < 1e-9:  # looking along `up`: any right-hand side will do
        x = np.cross(z, np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0]))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)


@dataclass(frozen=True)
class CameraSpec:
    """A dataset camera as declared: image size, intrinsics, look-at pose (world frame)."""

    name: str
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)

    @classmethod
    def parse(cls, section: Section, index: int) -> CameraSpec:
        """`{name, width, height, fovy (deg) | fx, fy, cx, cy, eye, target, up}`."""
        width = section.integer("width", 640, low=1)
        height = section.integer("height", 480, low=1)
        fovy = section.number("fovy", 60.0, low=1.0, high=179.0)
        focal = (height / 2.0) / math.tan(math.radians(fovy) / 2.0)
        if section.has("fovy") and (section.has("fx") or section.has("fy")):
            raise section.error("give either fovy or fx/fy, not both")
        spec = cls(
            name=section.string("name", f"camera{index}"),
            width=width,
            height=height,
            fx=section.number("fx", focal, low=1e-3),
            fy=section.number("fy", section.number("fx", focal, low=1e-3), low=1e-3),
            cx=section.number("cx", (width - 1) / 2.0),
            cy=section.number("cy", (height - 1) / 2.0),
            eye=_vec3(section, "eye", (1.0, 0.0, 1.0)),
            target=_vec3(section, "target", (0.0, 0.0, 0.0)),
            up=_vec3(section, "up", (0.0, 0.0, 1.0)),
        )
        section.done(
            ("name", "width", "height", "fovy", "fx", "fy", "cx", "cy", "eye", "target", "up")
        )
        if np.allclose(spec.eye, spec.target):
            raise section.error("eye and target must differ", "target")
        return spec

    def view(self) -> CameraView:
        """The camera as declared, before any randomiser moved it."""
        eye = np.array(self.eye)
        rotation = look_at(eye, np.array(self.target), np.array(self.up))
        return CameraView(self.name, self.width, self.height, self.fx, self.fy, self.cx, self.cy,
                          rotation, eye)  # fmt: skip


def _vec3(
    section: Section, name: str, default: tuple[float, float, float]
) -> tuple[float, float, float]:
    x, y, z = section.vector(name, 3, default)
    return (x, y, z)


@dataclass
class CameraView:
    """A camera for one frame: intrinsics and the world pose of its optical frame."""

    name: str
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    rotation: FloatArray
    """World-from-optical rotation (columns: optical x right, y down, z forward)."""
    position: FloatArray
    """Optical centre in the world frame (m)."""

    @property
    def matrix(self) -> FloatArray:
        """The 3x3 intrinsic matrix K."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def world_to_camera(self, points: FloatArray) -> FloatArray:
        """World points (N, 3) in the optical frame (N, 3)."""
        return (points - self.position) @ self.rotation

    def project(self, points_camera: FloatArray) -> FloatArray:
        """Pixel (u, v) of optical-frame points in front of the camera, (N, 2)."""
        z = points_camera[:, 2]
        return np.stack(
            [
                self.fx * points_camera[:, 0] / z + self.cx,
                self.fy * points_camera[:, 1] / z + self.cy,
            ],
            axis=1,
        )

    def pose_matrix(self) -> FloatArray:
        """4x4 world-from-camera (optical) transform."""
        out = np.eye(4)
        out[:3, :3] = self.rotation
        out[:3, 3] = self.position
        return out

    def apply_to(self, glcam: mujoco.MjvGLCamera, near: float, far: float) -> None:
        """Point an OpenGL scene camera like this one (pose and an off-centre frustum)."""
        glcam.pos[:] = self.position
        glcam.forward[:] = self.rotation[:, 2]
        glcam.up[:] = -self.rotation[:, 1]
        glcam.frustum_near = near
        glcam.frustum_far = far
        # Pixel i spans [i - 0.5, i + 0.5]; the near plane's edges follow from K.
        glcam.frustum_width = near * self.width / (2.0 * self.fx)
        glcam.frustum_center = near * (self.width / 2.0 - self.cx - 0.5) / self.fx
        top = near * (self.cy + 0.5) / self.fy
        glcam.frustum_top = top
        glcam.frustum_bottom = top - near * self.height / self.fy
        glcam.orthographic = 0
