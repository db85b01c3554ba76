"""The simulator: URDF import, scenes, the MuJoCo world, drives and the ROS interfaces."""

from __future__ import annotations

from simbridge.sim.control import DriveMode, DriveSpec, Trajectory
from simbridge.sim.scene import Scene, load_scene
from simbridge.sim.urdf import Robot, load_urdf
from simbridge.sim.world import World

__all__ = [
    "DriveMode",
    "DriveSpec",
    "Robot",
    "Scene",
    "Trajectory",
    "World",
    "load_scene",
    "load_urdf",
]
