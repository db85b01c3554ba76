"""Joint drives and controllers that run without ROS: drive laws, trajectories, followers."""

from __future__ import annotations

from simbridge.sim.control.diff_drive import (
    DiffDriveConfig,
    DiffDriveController,
    DiffDriveKinematics,
    DiffDriveLimits,
    Pose2D,
)
from simbridge.sim.control.drive import DriveMode, DriveSpec
from simbridge.sim.control.drive_bank import DriveBank, DriveTarget, add_drive_actuator
from simbridge.sim.control.follower import TrajectoryFollower
from simbridge.sim.control.trajectory import Trajectory, TrajectoryPoint

__all__ = [
    "DiffDriveConfig",
    "DiffDriveController",
    "DiffDriveKinematics",
    "DiffDriveLimits",
    "DriveBank",
    "DriveMode",
    "DriveSpec",
    "DriveTarget",
    "Pose2D",
    "Trajectory",
    "TrajectoryFollower",
    "TrajectoryPoint",
    "add_drive_actuator",
]
