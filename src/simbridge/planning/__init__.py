"""Motion planning on a MuJoCo model: FK, IK, RRT-Connect, timing, pick and place."""

from __future__ import annotations

from simbridge.planning.geometry import (
    FloatArray,
    Pose,
    matrix_to_quaternion,
    quaternion_to_matrix,
    rotation_error,
    top_down_orientation,
)
from simbridge.planning.ik import IKOptions, IKSolver
from simbridge.planning.kinematics import ArmKinematics, ArmSpec, Contact, niryo_one_arm
from simbridge.planning.mover import DEFAULT_PAYLOAD, MoverOptions, MoverPlanner, PickAndPlacePlan
from simbridge.planning.rrt import JointPathPlanner, PathOptions
from simbridge.planning.scene import (
    PAYLOAD_GEOM,
    BoxObstacle,
    Payload,
    add_obstacles,
    add_payload,
    build_planning_model,
)
from simbridge.planning.service import (
    MOVER_SERVICE_TYPE,
    MoverService,
    mover_response,
    pose_from_message,
    robot_trajectory_message,
)
from simbridge.planning.timing import JointTrajectory, time_parameterize

__all__ = [
    "DEFAULT_PAYLOAD",
    "MOVER_SERVICE_TYPE",
    "PAYLOAD_GEOM",
    "ArmKinematics",
    "ArmSpec",
    "BoxObstacle",
    "Contact",
    "FloatArray",
    "IKOptions",
    "IKSolver",
    "JointPathPlanner",
    "JointTrajectory",
    "MoverOptions",
    "MoverPlanner",
    "MoverService",
    "PathOptions",
    "Payload",
    "PickAndPlacePlan",
    "Pose",
    "add_obstacles",
    "add_payload",
    "build_planning_model",
    "matrix_to_quaternion",
    "mover_response",
    "niryo_one_arm",
    "pose_from_message",
    "quaternion_to_matrix",
    "robot_trajectory_message",
    "rotation_error",
    "time_parameterize",
    "top_down_orientation",
]
