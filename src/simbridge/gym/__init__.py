"""Gymnasium environments built from scene files: reach, pick and place, diff-drive navigation.

`import simbridge.gym` registers `simbridge/Reach-v0`, `simbridge/PickAndPlace-v0` and
`simbridge/DiffDriveNav-v0` for `gymnasium.make` and `gymnasium.make_vec`. Your own
environment is a `SceneEnv` of any scene, a `Task` (reset distribution, reward,
termination) and an `ActionAdapter`; docs/gym.md walks through one. Observations and
actions go through the same drives and sensor classes as the ROS side, so a trained
policy drives `simbridge sim` unchanged (`RosPolicyRunner`).
"""

from __future__ import annotations

from simbridge.gym.actions import (
    ActionAdapter,
    CombinedAction,
    EndEffectorDelta,
    GripperCommand,
    JointDelta,
    TwistCommand,
    WheelVelocity,
)
from simbridge.gym.ars import ARSConfig, ARSResult, LinearPolicy, train_ars
from simbridge.gym.batch import WorldBatch
from simbridge.gym.env import Observation, SceneEnv, look_at
from simbridge.gym.registration import ENV_IDS, register_envs
from simbridge.gym.ros_policy import Policy, RosPolicyRunner
from simbridge.gym.sensors import CameraImage, LidarRanges, SensorObservation
from simbridge.gym.task import Task
from simbridge.gym.vector import SceneVectorEnv

register_envs()

__all__ = [
    "ENV_IDS",
    "ARSConfig",
    "ARSResult",
    "ActionAdapter",
    "CameraImage",
    "CombinedAction",
    "EndEffectorDelta",
    "GripperCommand",
    "JointDelta",
    "LidarRanges",
    "LinearPolicy",
    "Observation",
    "Policy",
    "RosPolicyRunner",
    "SceneEnv",
    "SceneVectorEnv",
    "SensorObservation",
    "Task",
    "TwistCommand",
    "WheelVelocity",
    "WorldBatch",
    "look_at",
    "register_envs",
    "train_ars",
]
