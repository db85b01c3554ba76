"""MoverService over ROS messages: round trip through the registry, timing, empty on failure."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simbridge.errors import PlanningError
from simbridge.messages import default_registry
from simbridge.planning import (
    MOVER_SERVICE_TYPE,
    MoverPlanner,
    MoverService,
    pose_from_message,
    robot_trajectory_message,
    top_down_orientation,
)
from simbridge.planning.timing import time_parameterize


def _request(pick_xyz: list[float], place_xyz: list[float]) -> object:
    registry = default_registry()
    request = registry.new(f"{MOVER_SERVICE_TYPE}Request")
    request.joints_input.joints = np.zeros(6)
    for pose, xyz, yaw in (
        (request.pick_pose, pick_xyz, 0.3),
        (request.place_pose, place_xyz, 0.0),
    ):
        pose.position.x, pose.position.y, pose.position.z = xyz
        qx, qy, qz, qw = top_down_orientation(yaw)
        pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = (
            qx,
            qy,
            qz,
            qw,
        )
    return request


def test_trajectory_message_fields_and_timing() -> None:
    names = ("a", "b")
    traj = time_parameterize(
        np.array([[0.0, 0.0], [1.0, -0.5]]), names, np.array([1.0, 1.0]), np.array([2.0, 2.0])
    )
    registry = default_registry()
    message = robot_trajectory_message(traj, registry, frame_id="base_link")
    jt = message.joint_trajectory
    assert jt.joint_names == ["a", "b"]
    assert jt.header.frame_id == "base_link"
    assert len(jt.points) == len(traj)
    for point, t, q, v in zip(jt.points, traj.times, traj.positions, traj.velocities, strict=True):
        assert point.time_from_start.sec + point.time_from_start.nanosec * 1e-9 == pytest.approx(t)
        assert 0 <= point.time_from_start.nanosec < 1_000_000_000
        np.testing.assert_array_equal(point.positions, q)
        np.testing.assert_array_equal(point.velocities, v)
    last = jt.points[-1].time_from_start
    assert (last.sec, last.nanosec) == (1, 500_000_000)
    # survives the ROS 1 wire format
    data = registry.encode(message, "moveit_msgs/RobotTrajectory")
    decoded = registry.decode(data, "moveit_msgs/RobotTrajectory")
    np.testing.assert_array_equal(decoded.joint_trajectory.points[3].positions, traj.positions[3])


def test_service_answers_with_four_trajectories(mover: MoverPlanner) -> None:
    service = MoverService(mover)
    response = service(_request([0.25, 0.1, 0.125], [0.2, -0.15, 0.125]))
    assert service.last_error is None
    assert len(response.trajectories) == 4
    ends = [t.joint_trajectory.points[-1].positions for t in response.trajectories]
    starts = [t.joint_trajectory.points[0].positions for t in response.trajectories]
    np.testing.assert_array_equal(starts[0], np.zeros(6))
    for end, start in zip(ends[:-1], starts[1:], strict=True):
        np.testing.assert_array_equal(end, start)
    for trajectory in response.trajectories:
        assert trajectory.joint_trajectory.joint_names == [f"joint_{i}" for i in range(1, 7)]
    # the grasp ends 5 cm below the pre-grasp tool position
    assert service.last_plan is not None
    k = mover.kinematics
    drop = k.forward(service.last_plan.pre_grasp.end).position - k.forward(ends[1]).position
    np.testing.assert_allclose(drop, [0, 0, 0.05], atol=1e-3)
    encoded = default_registry().encode(response, f"{MOVER_SERVICE_TYPE}Response")
    assert len(encoded) > 1000


def test_unreachable_request_gets_an_empty_response_and_a_readable_error(
    mover: MoverPlanner,
) -> None:
    service = MoverService(mover)
    response = service(_request([0.25, 0.1, 0.125], [0.9, 0.0, 0.125]))
    assert list(response.trajectories) == []
    assert service.last_error is not None
    assert "place (place_pose)" in service.last_error
    assert "unreachable" in service.last_error
    assert service.last_plan is None


def test_zero_quaternion_is_rejected_not_crashing(mover: MoverPlanner) -> None:
    registry = default_registry()
    request = registry.new(f"{MOVER_SERVICE_TYPE}Request")  # all-zero poses
    service = MoverService(mover)
    assert list(service(request).trajectories) == []
    assert service.last_error is not None
    assert service.last_error.startswith("pick_pose: orientation must be a non-zero quaternion")
    with pytest.raises(PlanningError, match="place_pose"):
        pose_from_message(request.place_pose, "place_pose")


def test_duration_rounding_carries_into_seconds() -> None:
    traj = time_parameterize(np.array([[0.0], [1.0]]), ("j",), np.array([1.0]), np.array([2.0]))
    shifted = type(traj)(
        traj.joint_names,
        np.array([0.0, 2.9999999999]),
        traj.positions[[0, -1]],
        traj.velocities[[0, -1]],
        traj.accelerations[[0, -1]],
    )
    stamp = robot_trajectory_message(shifted).joint_trajectory.points[1].time_from_start
    assert (stamp.sec, stamp.nanosec) == (3, 0)
    assert math.isclose(stamp.sec + stamp.nanosec * 1e-9, 3.0)
