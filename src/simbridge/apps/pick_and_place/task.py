"""What one pick and place asks for: where the cube starts and where it must end up."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simbridge.errors import AppError
from simbridge.planning import Pose, top_down_orientation

__all__ = ["CUBE_SIZE", "PickAndPlaceTask"]

CUBE_SIZE = 0.05
"""Edge length (m) of the cube in the shipped scene."""

_REACH = (0.17, 0.30)
"""Distances (m) from the arm's base axis at which cubes and targets are drawn."""
_AZIMUTH = math.radians(70.0)
"""Largest bearing (rad) either side of the arm's x axis for random cubes and targets."""
_MIN_SEPARATION = 0.10
"""Smallest distance (m) between a random cube and its target, so they never overlap."""


def _wrap_quarter_turn(angle: float) -> float:
    """The angle in [-pi/4, pi/4) equivalent to ``angle`` for a cube (90-degree symmetric)."""
    quarter = math.pi / 2
    return (angle + quarter / 2) % quarter - quarter / 2


@dataclass(frozen=True)
class PickAndPlaceTask:
    """Cube start and place target on the table top (z = 0), positions in m, yaws in rad.

    Frames are the robot's base frame, which is also the scene's world frame.
    """

    cube_xy: tuple[float, float] = (0.22, 0.12)
    cube_yaw: float = 0.3
    target_xy: tuple[float, float] = (0.20, -0.15)
    target_yaw: float = 0.0
    cube_size: float = CUBE_SIZE
    place_clearance: float = 0.008
    """How far above the table (m) the cube is let go."""

    def __post_init__(self) -> None:
        for name in ("cube_xy", "target_xy"):
            x, y = getattr(self, name)
            reach = math.hypot(x, y)
            if not _REACH[0] - 1e-9 <= reach <= 0.40:
                raise AppError(
                    f"{name}={getattr(self, name)!r} is {reach:.3f} m from the base; "
                    f"choose a point {_REACH[0]} to 0.40 m away"
                )
        if self.cube_size <= 0:
            raise AppError(f"cube_size must be > 0, got {self.cube_size}")

    @classmethod
    def random(cls, seed: int) -> PickAndPlaceTask:
        """A reachable cube and target drawn from ``seed`` (same seed, same task)."""
        rng = np.random.default_rng(seed)

        def point() -> tuple[float, float]:
            radius = float(rng.uniform(*_REACH))
            bearing = float(rng.uniform(-_AZIMUTH, _AZIMUTH))
            return radius * math.cos(bearing), radius * math.sin(bearing)

        cube = point()
        target = point()
        while math.dist(cube, target) < _MIN_SEPARATION:
            target = point()
        quarter = math.pi / 4
        return cls(
            cube_xy=cube,
            cube_yaw=float(rng.uniform(-quarter, quarter)),
            target_xy=target,
            target_yaw=float(rng.uniform(-quarter, quarter)),
        )

    @property
    def cube_center(self) -> tuple[float, float, float]:
        """The cube's starting centre (resting on the table)."""
        return (self.cube_xy[0], self.cube_xy[1], self.cube_size / 2)

    @property
    def target_center(self) -> tuple[float, float, float]:
        """Where the cube's centre must end up."""
        return (self.target_xy[0], self.target_xy[1], self.cube_size / 2)

    def grasp_yaw(self) -> float:
        """Gripper yaw for the cube: its yaw modulo 90 degrees, closest to the arm's bearing.

        Squaring up to the cube's faces is what lets the 2-finger gripper close on them;
        choosing the face pair that faces the base keeps the wrist near its middle.
        """
        bearing = math.atan2(self.cube_xy[1], self.cube_xy[0])
        return bearing + _wrap_quarter_turn(self.cube_yaw - bearing)

    def release_yaw(self) -> float:
        """Gripper yaw at the target that sets the cube down at ``target_yaw`` (mod 90 deg)."""
        bearing = math.atan2(self.target_xy[1], self.target_xy[0])
        return bearing + _wrap_quarter_turn(self.target_yaw - bearing)

    def pick_pose(self, grasp_offset: float, grasp_drop: float = 0.05) -> Pose:
        """Tool pose above the cube, as the tutorial's pick_pose: the grasp is grasp_drop lower.

        ``grasp_offset`` is the distance from the tool frame to the point between the pads.
        """
        x, y, z = self.cube_center
        return Pose([x, y, z + grasp_offset + grasp_drop], top_down_orientation(self.grasp_yaw()))

    def place_pose(self, grasp_offset: float) -> Pose:
        """Tool pose that holds the cube just above its target."""
        x, y, z = self.target_center
        height = z + grasp_offset + self.place_clearance
        return Pose([x, y, height], top_down_orientation(self.release_yaw()))
