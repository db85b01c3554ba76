"""Between ROS messages and the planner/simulator types: poses and joint trajectories."""

from __future__ import annotations

import math
from typing import Any

from simbridge.errors import AppError
from simbridge.messages import MessageRegistry
from simbridge.planning import JointTrajectory, Pose
from simbridge.sim import Trajectory

__all__ = ["pose_from_msg", "pose_to_msg", "robot_trajectory_msg", "sim_trajectory"]


def pose_to_msg(registry: MessageRegistry, pose: Pose) -> Any:
    """A geometry_msgs/Pose for a planner pose."""
    x, y, z = (float(v) for v in pose.position)
    qx, qy, qz, qw = (float(v) for v in pose.orientation)
    return registry.new(
        "geometry_msgs/Pose",
        position={"x": x, "y": y, "z": z},
        orientation={"x": qx, "y": qy, "z": qz, "w": qw},
    )


def pose_from_msg(msg: Any) -> Pose:
    """A planner pose from a geometry_msgs/Pose (ValueError for a zero quaternion)."""
    p, q = msg.position, msg.orientation
    return Pose([p.x, p.y, p.z], [q.x, q.y, q.z, q.w])


def robot_trajectory_msg(registry: MessageRegistry, trajectory: JointTrajectory) -> Any:
    """A moveit_msgs/RobotTrajectory holding ``trajectory`` as its joint_trajectory."""
    points = []
    for i, t in enumerate(trajectory.times):
        sec = math.floor(float(t))
        nanosec = min(round((float(t) - sec) * 1e9), 999_999_999)
        points.append(
            registry.new(
                "trajectory_msgs/JointTrajectoryPoint",
                positions=trajectory.positions[i].copy(),
                velocities=trajectory.velocities[i].copy(),
                accelerations=trajectory.accelerations[i].copy(),
                time_from_start={"sec": sec, "nanosec": nanosec},
            )
        )
    msg = registry.new("moveit_msgs/RobotTrajectory")
    msg.joint_trajectory.joint_names = list(trajectory.joint_names)
    msg.joint_trajectory.points = points
    return msg


def sim_trajectory(msg: Any) -> Trajectory:
    """The simulator trajectory of a moveit_msgs/RobotTrajectory's joint_trajectory.

    Points keep their time_from_start, positions and (when every point has them) velocities.
    """
    joint_trajectory = msg.joint_trajectory
    names = list(joint_trajectory.joint_names)
    points = list(joint_trajectory.points)
    if not names or not points:
        raise AppError("the planner sent a trajectory with no joints or no points")
    times = [p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in points]
    positions = [list(p.positions) for p in points]
    with_velocities = all(len(p.velocities) == len(names) for p in points)
    velocities = [list(p.velocities) for p in points] if with_velocities else None
    return Trajectory.from_lists(names, times, positions, velocities)
