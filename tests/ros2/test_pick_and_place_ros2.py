"""Pick and place over ROS 2: the planner as an rclpy node serving MoverService.

`simbridge planner --backend ros2` and `simbridge demo pick-and-place --backend ros2` run
as processes of the ROS 2 venv (niryo_moveit built into it by `make ros2`); independent
rclpy nodes (tests/ros2/ros2_node.py) call the planner and read /rosout.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import pytest

from simbridge.apps.pick_and_place import PickAndPlaceTask
from simbridge.planning import Pose, top_down_orientation
from tests.ros2support import Ros2Process

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(300)]

SERVICE = "/niryo_moveit"
SRV_TYPE = "niryo_moveit/srv/MoverService"
GRASP_OFFSET = 0.05


def _pose(p: Pose) -> dict[str, Any]:
    x, y, z = (float(v) for v in p.position)
    qx, qy, qz, qw = (float(v) for v in p.orientation)
    return {"position": {"x": x, "y": y, "z": z},
            "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}}  # fmt: skip


def _request(pick: Pose) -> str:
    task = PickAndPlaceTask()
    return json.dumps(
        {
            "joints_input": {"joints": [0.0] * 6},
            "pick_pose": _pose(pick),
            "place_pose": _pose(task.place_pose(GRASP_OFFSET)),
        }
    )


@pytest.fixture(scope="module")
def planner() -> Iterator[Ros2Process]:
    with Ros2Process(["-m", "simbridge.cli", "planner", "--backend", "ros2"]) as proc:
        proc.expect_line(r"serving /niryo_moveit \[niryo_moveit/MoverService\]", timeout=120)
        yield proc


def test_an_rclpy_client_gets_four_trajectories(planner: Ros2Process) -> None:
    pick = PickAndPlaceTask().pick_pose(GRASP_OFFSET)
    with Ros2Process.node("call", SERVICE, SRV_TYPE, _request(pick), "60") as client:
        response = client.expect_json("response", timeout=90)
    assert len(response["trajectories"]) == 4
    first = response["trajectories"][0]["joint_trajectory"]
    assert first["joint_names"] == [f"joint_{i}" for i in range(1, 7)]
    last = response["trajectories"][3]["joint_trajectory"]["points"][-1]["time_from_start"]
    assert last["sec"] + last["nanosec"] * 1e-9 > 0.5  # ROS 2 Duration fields


def test_unreachable_goal_empty_answer_and_reason_on_rosout(planner: Ros2Process) -> None:
    far = Pose([0.0, 0.95, 0.3], top_down_orientation())
    # /rosout is transient local (rcl keeps 1000): a late match still gets the error.
    with Ros2Process.node(
        "echo", "/rosout", "rcl_interfaces/msg/Log", "1000", "--latched"
    ) as rosout:
        assert rosout.expect_json("ready", timeout=60) is True
        with Ros2Process.node("call", SERVICE, SRV_TYPE, _request(far), "60") as client:
            response = client.expect_json("response", timeout=90)
        assert response["trajectories"] == []
        while True:  # other nodes log too; the planner's ERROR names the reason
            log = rosout.expect_json("msg", timeout=30)
            if log["name"] == "niryo_moveit_planner" and log["level"] == 40:
                break
    assert "no valid plan" in log["msg"]


def test_demo_end_to_end() -> None:
    with Ros2Process(
        ["-m", "simbridge.cli", "demo", "pick-and-place", "--backend", "ros2", "--json"]
    ) as demo:
        success = demo.expect_json("success", timeout=240)
        result = json.loads(demo.output[-1])
    assert success is True, "".join(demo.output[-20:])
    assert result["backend"] == "ros2"
    assert result["cube_error_m"] < 0.01
    assert result["trajectories"] == 4
