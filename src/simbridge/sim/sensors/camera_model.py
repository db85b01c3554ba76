"""Pinhole intrinsics (CameraInfo) and the REP 103 optical frame of a rendered camera."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from simbridge.errors import SimError
from simbridge.sim.sensors.frames import Pose
from simbridge.sim.sensors.rosmsg import new_message

__all__ = ["OPTICAL_FROM_BODY", "PinholeModel", "optical_pose"]

# Columns: the optical frame's x (right), y (down), z (forward) in ROS body axes
# (x forward, y left, z up), per REP 103.
OPTICAL_FROM_BODY = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def optical_pose(body_pose: Pose) -> Pose:
    """The optical frame (z forward, x right, y down) at a camera's body-axes pose."""
    return Pose(body_pose.position.copy(), body_pose.rotation @ OPTICAL_FROM_BODY)


@dataclass(frozen=True)
class PinholeModel:
    """An ideal pinhole camera: square pixels, principal point at the image centre.

    Pixel centres sit at integer (u, v), so the centre of a W x H image is
    ((W - 1) / 2, (H - 1) / 2) and fy = (H / 2) / tan(fovy / 2).
    """

    width: int
    height: int
    fovy: float

    def __post_init__(self) -> None:
        if self.width < 1 or self.height < 1:
            raise SimError(f"camera resolution must be positive, got {self.width}x{self.height}")
        if not 0.0 < self.fovy < math.pi:
            raise SimError(f"camera fovy must lie in (0, pi) radians, got {self.fovy}")

    @property
    def focal(self) -> float:
        """Focal length in pixels (fx = fy)."""
        return (self.height / 2.0) / math.tan(self.fovy / 2.0)

    @property
    def center(self) -> tuple[float, float]:
        """Principal point (cx, cy) in pixels."""
        return ((self.width - 1) / 2.0, (self.height - 1) / 2.0)

    def matrix(self) -> NDArray[np.float64]:
        """The 3x3 intrinsic matrix K."""
        cx, cy = self.center
        f = self.focal
        return np.array([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]])

    def project(self, points_optical: NDArray[np.float64]) -> NDArray[np.float64]:
        """Pixel (u, v) of points given in the optical frame (N, 3) -> (N, 2)."""
        homogeneous = points_optical @ self.matrix().T
        return homogeneous[:, :2] / homogeneous[:, 2:3]

    def rays(self) -> NDArray[np.float64]:
        """Per-pixel (x/z, y/z) of the optical ray through every pixel centre, (H, W, 2)."""
        cx, cy = self.center
        u = (np.arange(self.width) - cx) / self.focal
        v = (np.arange(self.height) - cy) / self.focal
        uu, vv = np.meshgrid(u, v)
        return np.stack([uu, vv], axis=-1)

    def camera_info(self, header: Any) -> Any:
        """sensor_msgs/CameraInfo (plumb_bob, zero distortion) for this model."""
        k = self.matrix()
        p = np.hstack([k, np.zeros((3, 1))])
        return new_message(
            "sensor_msgs/CameraInfo",
            header=header,
            height=self.height,
            width=self.width,
            distortion_model="plumb_bob",
            D=np.zeros(5),
            K=k.ravel(),
            R=np.eye(3).ravel(),
            P=p.ravel(),
            binning_x=0,
            binning_y=0,
            roi=new_message(
                "sensor_msgs/RegionOfInterest",
                x_offset=0,
                y_offset=0,
                height=0,
                width=0,
                do_rectify=False,
            ),
        )
