"""The shipped control_msgs definitions match ROS's (checksums as rosmsg md5 prints them on
a noetic system), so real actionlib clients and controllers accept our messages."""

from __future__ import annotations

import pytest

from simbridge.messages import default_registry

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
