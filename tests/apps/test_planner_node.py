"""The /niryo_moveit planner node: good plans, and empty answers with a readable reason."""

from __future__ import annotations

import itertools
import queue
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from simbridge.apps.pick_and_place import (
    PLANNER_SERVICE,
    SERVICE_TYPE,
    LocalPlannerNode,
    MoverServiceHandler,
    PickAndPlaceTask,
    planner_for_scene,
)
from simbridge.apps.pick_and_place.conversion import pose_to_msg, sim_trajectory
from simbridge.connector import Connector
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus
from simbridge.messages import default_registry
from simbridge.planning import MoverPlanner, Pose, top_down_orientation

REG = default_registry()
GRASP_OFFSET = 0.05  # tool_link to grasp_link in the shipped URDF
ARM = tuple(f"joint_{i}" for i in range(1, 7))


@pytest.fixture(scope="module")
def planner() -> MoverPlanner:
    return planner_for_scene()


def request(pick: Pose, place: Pose, joints: tuple[float, ...] = (0.0,) * 6) -> Any:
    req = REG.new("niryo_moveit/MoverServiceRequest")
    req.joints_input.joints = np.array(joints)
    req.pick_pose = pose_to_msg(REG, pick)
    req.place_pose = pose_to_msg(REG, place)
    return req


def task_request() -> Any:
    task = PickAndPlaceTask()
    return request(task.pick_pose(GRASP_OFFSET), task.place_pose(GRASP_OFFSET))


def test_plan_has_four_timed_trajectories_from_the_start_joints(planner: MoverPlanner) -> None:
    errors: list[str] = []
    handler = MoverServiceHandler(planner, REG, errors.append)
    start = (0.1, -0.2, 0.3, 0.0, -0.4, 0.2)
    task = PickAndPlaceTask()
    response = handler(request(task.pick_pose(GRASP_OFFSET), task.place_pose(GRASP_OFFSET), start))
    assert errors == []
    assert len(response.trajectories) == 4
    trajectories = [sim_trajectory(t) for t in response.trajectories]
    for msg, trajectory in zip(response.trajectories, trajectories, strict=True):
        assert tuple(msg.joint_trajectory.joint_names) == ARM
        assert trajectory.points[0].time == 0.0
        assert trajectory.duration > 0.2
    assert trajectories[0].points[0].positions == pytest.approx(start)
    # consecutive trajectories join up; pick up retraces the grasp
    for before, after in itertools.pairwise(trajectories):
        assert after.points[0].positions == pytest.approx(before.points[-1].positions)
    assert trajectories[2].points[-1].positions == pytest.approx(
        trajectories[1].points[0].positions
    )
    # the grasp goes straight down by the tutorial's 5 cm, orientation unchanged
    kin = planner.kinematics
    above = kin.forward(np.array(trajectories[1].points[0].positions))
    at = kin.forward(np.array(trajectories[1].points[-1].positions))
    assert at.position - above.position == pytest.approx([0.0, 0.0, -0.05], abs=1e-3)
    pick = task.pick_pose(GRASP_OFFSET)
    assert above.position == pytest.approx(pick.position, abs=1e-3)
    place = kin.forward(np.array(trajectories[3].points[-1].positions))
    assert place.position == pytest.approx(task.place_pose(GRASP_OFFSET).position, abs=1e-3)


@pytest.mark.parametrize(
    ("pick", "reason"),
    [
        (Pose([0.9, 0.0, 0.2], top_down_orientation()), "unreachable"),
        (Pose([0.25, 0.0, -0.02], top_down_orientation()), "collision"),
    ],
    ids=["out-of-reach", "inside-the-table"],
)
def test_impossible_goal_gets_an_empty_answer_and_a_reason(
    planner: MoverPlanner, pick: Pose, reason: str
) -> None:
    errors: list[str] = []
    handler = MoverServiceHandler(planner, REG, errors.append)
    place = PickAndPlaceTask().place_pose(GRASP_OFFSET)
    response = handler(request(pick, place))
    assert list(response.trajectories) == []
    assert len(errors) == 1
    assert reason in errors[0]
    assert "pick_pose" in errors[0]
    assert handler.last_error == errors[0]


def test_malformed_bytes_and_zero_quaternion_are_answered_not_raised(
    planner: MoverPlanner,
) -> None:
    errors: list[str] = []
    handler = MoverServiceHandler(planner, REG, errors.append)
    empty = REG.decode(handler.serialized(b"\x01\x02"), "niryo_moveit/MoverServiceResponse")
    assert list(empty.trajectories) == []
    assert errors[-1].startswith("bad request")
    req = task_request()
    q = req.pick_pose.orientation
    q.x = q.y = q.z = q.w = 0.0
    assert list(handler(req).trajectories) == []
    assert "orientation" in errors[-1]


@pytest.fixture
def bridge() -> Iterator[tuple[LocalPlannerNode, Connector]]:
    bus = LocalBus()
    with (
        EndpointThread(EndpointOptions(port=0), bus) as endpoint,
        LocalPlannerNode(bus) as node,
        Connector("127.0.0.1", endpoint.port).connect() as connector,
    ):
        yield node, connector


def test_unreachable_goal_over_the_bridge_returns_empty_and_logs_to_rosout(
    bridge: tuple[LocalPlannerNode, Connector],
) -> None:
    _, connector = bridge
    logs: queue.Queue[Any] = queue.Queue()
    connector.subscribe("/rosout", "rosgraph_msgs/Log", logs.put)
    connector.register_ros_service(PLANNER_SERVICE, SERVICE_TYPE)
    place = PickAndPlaceTask().place_pose(GRASP_OFFSET)
    far = Pose([0.0, 0.95, 0.3], top_down_orientation())
    response = connector.call(PLANNER_SERVICE, request(far, place), timeout=30)
    assert list(response.trajectories) == []
    log = logs.get(timeout=5)
    assert log.level == 8  # ERROR
    assert log.name == "/niryo_moveit_planner"
    assert "unreachable" in log.msg
    # the node is still serving: a good request plans
    good = connector.call(PLANNER_SERVICE, task_request(), timeout=30)
    assert len(good.trajectories) == 4
