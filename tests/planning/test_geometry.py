"""Quaternion/matrix conversions, rotation errors and the top-down grasp orientation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.planning import (
    Pose,
    matrix_to_quaternion,
    quaternion_to_matrix,
    rotation_error,
    top_down_orientation,
)

unit = st.floats(-1.0, 1.0, allow_nan=False)


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.asarray(np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k)


def test_known_quaternions() -> None:
    # 90 degrees about z: x -> y
    rot = quaternion_to_matrix([0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)])
    np.testing.assert_allclose(rot @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    # 180 degrees about x
    np.testing.assert_allclose(quaternion_to_matrix([1, 0, 0, 0]), np.diag([1, -1, -1]))


@settings(max_examples=200, deadline=None)
@given(unit, unit, unit, unit)
def test_quaternion_round_trip(x: float, y: float, z: float, w: float) -> None:
    quat = np.array([x, y, z, w])
    if np.linalg.norm(quat) < 1e-3:
        return
    rot = quaternion_to_matrix(quat)
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-9)
    assert np.linalg.det(rot) == pytest.approx(1.0)
    np.testing.assert_allclose(quaternion_to_matrix(matrix_to_quaternion(rot)), rot, atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(unit, unit, unit, st.floats(0.0, math.pi, allow_nan=False))
def test_rotation_error_is_the_axis_angle(x: float, y: float, z: float, angle: float) -> None:
    axis = np.array([x, y, z])
    if np.linalg.norm(axis) < 1e-3:
        return
    start = _axis_angle(np.array([0.3, -0.2, 0.9]), 0.7)
    goal = _axis_angle(axis, angle) @ start
    err = rotation_error(start, goal)
    assert np.linalg.norm(err) == pytest.approx(angle, abs=1e-6)
    # applying the returned rotation vector reproduces the goal
    if angle > 1e-9:
        np.testing.assert_allclose(
            _axis_angle(err, float(np.linalg.norm(err))) @ start, goal, atol=1e-6
        )


@pytest.mark.parametrize("yaw", [0.0, 0.5, -1.2, math.pi])
def test_top_down_points_tool_x_down(yaw: float) -> None:
    rot = quaternion_to_matrix(top_down_orientation(yaw))
    np.testing.assert_allclose(rot[:, 0], [0, 0, -1], atol=1e-12)
    # the remaining axes turn with yaw about the vertical
    np.testing.assert_allclose(rot[:, 1], [-math.sin(yaw), math.cos(yaw), 0], atol=1e-12)


def test_top_down_matches_unity_tutorial_orientation() -> None:
    """Unity Euler(90, 0, 0) converted to ROS (FLU) is the quaternion (0, 0.7071, 0, 0.7071)."""
    np.testing.assert_allclose(
        top_down_orientation(0.0), [0, math.sqrt(0.5), 0, math.sqrt(0.5)], atol=1e-12
    )


def test_pose_validation_and_helpers() -> None:
    pose = Pose([0.1, 0.2, 0.3], [0, 0, 0, 2])
    np.testing.assert_allclose(pose.orientation, [0, 0, 0, 1])
    np.testing.assert_allclose(pose.translated(dz=-0.05).position, [0.1, 0.2, 0.25])
    assert "z=0.300" in pose.describe()
    with pytest.raises(ValueError, match="quaternion"):
        Pose([0, 0, 0], [0, 0, 0, 0])
    with pytest.raises(ValueError, match="3 finite"):
        Pose([0, 0], [0, 0, 0, 1])
