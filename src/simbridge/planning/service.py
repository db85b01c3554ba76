"""ROS messages for the planner: moveit_msgs/RobotTrajectory and the niryo_moveit/MoverService."""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

from simbridge.errors import PlanningError
from simbridge.messages import MessageRegistry, default_registry
from simbridge.planning.geometry import Pose
from simbridge.planning.mover import MoverPlanner, PickAndPlacePlan
from simbridge.planning.timing import JointTrajectory

__all__ = [
    "MOVER_SERVICE_TYPE",
    "MoverService",
    "mover_response",
    "pose_from_message",
    "robot_trajectory_message",
]

MOVER_SERVICE_TYPE = "niryo_moveit/MoverService"

_log = logging.getLogger(__name__)


def _duration(registry: MessageRegistry, seconds: float) -> Any:
    sec = math.floor(seconds)
    nanosec = round((seconds - sec) * 1e9)
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return registry.new("builtin_interfaces/msg/Duration", sec=int(sec), nanosec=int(nanosec))


def robot_trajectory_message(
    trajectory: JointTrajectory, registry: MessageRegistry | None = None, frame_id: str = ""
) -> Any:
    """A moveit_msgs/RobotTrajectory with positions, velocities, accelerations and timing."""
    registry = registry or default_registry()
    points = [
        registry.new(
            "trajectory_msgs/JointTrajectoryPoint",
            positions=np.array(trajectory.positions[i], dtype=np.float64),
            velocities=np.array(trajectory.velocities[i], dtype=np.float64),
            accelerations=np.array(trajectory.accelerations[i], dtype=np.float64),
            time_from_start=_duration(registry, float(trajectory.times[i])),
        )
        for i in range(len(trajectory))
    ]
    message = registry.new("moveit_msgs/RobotTrajectory")
    message.joint_trajectory.header.frame_id = frame_id
    message.joint_trajectory.joint_names = list(trajectory.joint_names)
    message.joint_trajectory.points = points
    return message


def mover_response(plan: PickAndPlacePlan | None, registry: MessageRegistry | None = None) -> Any:
    """niryo_moveit/MoverServiceResponse: four trajectories, or none when planning failed."""
    registry = registry or default_registry()
    response = registry.new("niryo_moveit/MoverServiceResponse")
    if plan is not None:
        response.trajectories = [robot_trajectory_message(t, registry) for t in plan.trajectories]
    return response


def pose_from_message(message: Any, what: str = "pose") -> Pose:
    """A planning Pose from a geometry_msgs/Pose; a zero quaternion is a PlanningError."""
    p, o = message.position, message.orientation
    try:
        return Pose([p.x, p.y, p.z], [o.x, o.y, o.z, o.w])
    except ValueError as exc:
        raise PlanningError(f"{what}: {exc}") from exc


class MoverService:
    """Answers niryo_moveit/MoverService requests like the tutorial's mover.py.

    ``joints_input.joints`` are the current arm joints in radians; poses are tool goals in the
    planner's base frame. A failed plan returns an empty response, logs the reason and keeps it
    in ``last_error`` (None after a success) for the caller to report.
    """

    def __init__(self, planner: MoverPlanner, registry: MessageRegistry | None = None) -> None:
        self.planner = planner
        self.registry = registry or default_registry()
        self.last_error: str | None = None
        self.last_plan: PickAndPlacePlan | None = None

    def __call__(self, request: Any) -> Any:
        """Plan for ``request`` and return the response message (never raises PlanningError)."""
        try:
            joints = np.asarray(request.joints_input.joints, dtype=np.float64)
            pick = pose_from_message(request.pick_pose, "pick_pose")
            place = pose_from_message(request.place_pose, "place_pose")
            plan = self.planner.plan(joints, pick, place)
        except PlanningError as exc:
            self.last_error, self.last_plan = str(exc), None
            _log.warning("pick and place planning failed: %s", exc)
            return mover_response(None, self.registry)
        self.last_error, self.last_plan = None, plan
        return mover_response(plan, self.registry)
