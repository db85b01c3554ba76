"""Scene files: YAML describing robots, objects, lights, physics and ROS interfaces."""

from __future__ import annotations

from simbridge.sim.scene.builder import BuiltRobot, BuiltScene, build_scene
from simbridge.sim.scene.loader import SHAPES, load_scene, parse_scene, with_overrides
from simbridge.sim.scene.spec import (
    CommandTopics,
    ControllerSpec,
    GripperControllerSpec,
    GroupControllerSpec,
    JointConstraint,
    LightSpec,
    ObjectSpec,
    PhysicsSettings,
    RobotRos,
    RobotSpec,
    RosSettings,
    Scene,
    TrajectoryControllerSpec,
)
from simbridge.sim.urdf.robot import Origin

__all__ = [
    "SHAPES",
    "BuiltRobot",
    "BuiltScene",
    "CommandTopics",
    "ControllerSpec",
    "GripperControllerSpec",
    "GroupControllerSpec",
    "JointConstraint",
    "LightSpec",
    "ObjectSpec",
    "Origin",
    "PhysicsSettings",
    "RobotRos",
    "RobotSpec",
    "RosSettings",
    "Scene",
    "TrajectoryControllerSpec",
    "build_scene",
    "load_scene",
    "parse_scene",
    "with_overrides",
]
