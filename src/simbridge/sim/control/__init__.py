"""Joint drives and controllers that run without ROS: drive laws, trajectories, followers."""

from __future__ import annotations

from simbridge.sim.control.drive import DriveMode, DriveSpec
from simbridge.sim.control.drive_bank import DriveBank, DriveTarget, add_drive_actuator
from simbridge.sim.control.follower import TrajectoryFollower
from simbridge.sim.control.trajectory import Trajectory, TrajectoryPoint

__all__ = [
    "DriveBank",
    "DriveMode",
    "DriveSpec",
    "DriveTarget",
    "Trajectory",
    "TrajectoryFollower",
    "TrajectoryPoint",
    "add_drive_actuator",
]
