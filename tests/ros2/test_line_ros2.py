"""`simbridge demo line --backend ros2`: the line's robots driven only through the
controllers' ROS 2 actions, from an rclpy process of their own, and the parts still arrive
with the JSON summary of the other backends."""

from __future__ import annotations

import json

import pytest

from simbridge.apps.line import LineResult
from tests.ros2support import Ros2Process

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(300)]

STATUS = "/arm_out/arm_controller/follow_joint_trajectory/_action/status"


def test_line_delivers_through_ros2_actions() -> None:
    with Ros2Process.node("echo", STATUS, "action_msgs/msg/GoalStatusArray", "1") as status:
        assert status.expect_json("ready", timeout=60) is True
        with Ros2Process(
            ["-m", "simbridge.cli", "demo", "line", "--backend", "ros2", "--parts", "1",
             "--seed", "2", "--json"]
        ) as demo:  # fmt: skip
            seen = status.expect_json("msg", timeout=240)  # arm_out's goal, over DDS
            demo.expect_json("success", timeout=240)
            demo.proc.wait(60)
    output = "".join(demo.output)
    summary = json.loads(demo.output[-1])
    assert demo.proc.returncode == 0, output[-3000:]
    assert set(summary) == set(LineResult(0, 0, (), 0.0, 0.0, 1.0, {}).to_dict())
    assert (summary["success"], summary["backend"], summary["parts"]) == (True, "ros2", 1)
    assert summary["delivered"] == 1
    assert summary["placement_error_m"][0] < 0.02
    # arm_in: pre-grasp, grasp, close, pick up, place, open, retreat; the conveyor: one move.
    goals = {name: robot["goals"] for name, robot in summary["robots"].items()}
    assert goals == {"arm_in": 7, "arm_out": 7, "conveyor": 1}
    assert all(robot["joint_states"] > 0 for robot in summary["robots"].values())
    assert "driven from a ROS 2 process of their own" in output
    assert "ROS 2 cells ready" in output
    assert seen["status_list"]  # a goal's status, as a plain rclpy node sees it
