"""The shipped control_msgs definitions match ROS's: noetic's for ROS 1 (checksums as rosmsg
md5 prints them on a noetic system), so real actionlib clients and controllers accept our
messages; control_msgs 5.x (Jazzy) for ROS 2, from the package's ros2/ folder (field lists
here; tests/ros2/test_ros2_controllers.py checks the type hashes on the graph)."""

from __future__ import annotations

import pytest

from simbridge.messages import default_registry, ros2_registry

NOETIC_MD5 = {
    "control_msgs/FollowJointTrajectoryActionGoal": "cff5c1d533bf2f82dd0138d57f4304bb",
    "control_msgs/FollowJointTrajectoryActionFeedback": "d8920dc4eae9fc107e00999cce4be641",
    "control_msgs/JointTrajectoryControllerState": "10817c60c2486ef6b33e97dcd87f4474",
}


@pytest.mark.parametrize(("name", "md5"), sorted(NOETIC_MD5.items()))
def test_control_msgs_checksums(name: str, md5: str) -> None:
    assert default_registry().md5(name) == md5


def test_follow_joint_trajectory_result_codes() -> None:
    result = default_registry().msg_class("control_msgs/FollowJointTrajectoryResult")
    codes = {
        "SUCCESSFUL": 0,
        "INVALID_GOAL": -1,
        "INVALID_JOINTS": -2,
        "OLD_HEADER_TIMESTAMP": -3,
        "PATH_TOLERANCE_VIOLATED": -4,
        "GOAL_TOLERANCE_VIOLATED": -5,
    }
    for name, value in codes.items():
        assert getattr(result, name) == value


JAZZY_FIELDS = {
    "control_msgs/FollowJointTrajectoryGoal": [
        "trajectory",
        "multi_dof_trajectory",
        "path_tolerance",
        "component_path_tolerance",
        "goal_tolerance",
        "component_goal_tolerance",
        "goal_time_tolerance",
    ],
    "control_msgs/FollowJointTrajectoryResult": ["error_code", "error_string"],
    "control_msgs/FollowJointTrajectoryFeedback": [
        "header",
        "joint_names",
        "desired",
        "actual",
        "error",
        "multi_dof_joint_names",
        "multi_dof_desired",
        "multi_dof_actual",
        "multi_dof_error",
    ],
    "control_msgs/JointTrajectoryControllerState": [
        "header",
        "joint_names",
        "reference",
        "feedback",
        "error",
        "output",
        "multi_dof_joint_names",
        "multi_dof_reference",
        "multi_dof_feedback",
        "multi_dof_error",
        "multi_dof_output",
        "speed_scaling_factor",
    ],
    "control_msgs/JointComponentTolerance": [
        "joint_name",
        "component",
        "position",
        "velocity",
        "acceleration",
    ],
    "control_msgs/JointTolerance": ["name", "position", "velocity", "acceleration"],
    "control_msgs/GripperCommandGoal": ["command"],
}
"""control_msgs 5.8.0 (the Jazzy release) field order."""


@pytest.mark.parametrize(("name", "fields"), sorted(JAZZY_FIELDS.items()))
def test_ros2_layouts_are_jazzys(name: str, fields: list[str]) -> None:
    assert [f.name for f in ros2_registry().schema(name).fields] == fields


def test_ros1_keeps_noetics_layouts() -> None:
    state = default_registry().schema("control_msgs/JointTrajectoryControllerState")
    assert [f.name for f in state.fields] == ["header", "joint_names", "desired", "actual", "error"]
    assert not default_registry().has("control_msgs/JointComponentTolerance")
    goal = ros2_registry().schema("control_msgs/FollowJointTrajectoryGoal")
    assert {f.name: f.type for f in goal.fields}["multi_dof_trajectory"] == (
        "trajectory_msgs/MultiDOFJointTrajectory"
    )
