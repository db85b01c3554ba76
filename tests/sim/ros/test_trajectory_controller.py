"""joint_trajectory_controller of a namespaced robot, driven through the connector's action
client on the local bus (goals, feedback, tolerances, preemption, cancel, error codes)."""

from __future__ import annotations

import queue
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from simbridge.connector import ActionClient, Connector, ConnectorOptions
from simbridge.endpoint import EndpointOptions, EndpointThread, Node, NodeActionClient
from simbridge.errors import SimError
from simbridge.messages import default_registry
from simbridge.messages.actionlib import ABORTED, ACTIVE, PREEMPTED, REJECTED, SUCCEEDED
from simbridge.sim.control import Trajectory
from simbridge.sim.ros import JointTrajectoryController, SimRosBridge
from simbridge.sim.scene import load_scene
from simbridge.sim.world import World
from tests.sim.bridged import BridgedWorld
from tests.sim.worlds import arm_scene
from tests.waiting import wait_for

REG = default_registry()
ACTION = "control_msgs/FollowJointTrajectory"
NAME = "/arm_left/arm_controller/follow_joint_trajectory"


def _scene(tmp_path: Path, controller: dict[str, Any] | None = None) -> Path:
    spec = {
        "type": "joint_trajectory_controller",
        "joints": ["shoulder", "elbow", "wrist"],
        "constraints": {"goal_time": 0.5, "elbow": {"goal": 0.01}},
        **(controller or {}),
    }
    scene = {
        "physics": {"timestep": 0.002, "gravity": [0, 0, 0]},
        "robots": [
            {
                "urdf": "arm.urdf",
                "ros": {
                    "namespace": "/arm_left",
                    "frame_prefix": "arm_left/",
                    "controllers": {"arm_controller": spec},
                },
            }
        ],
    }
    return arm_scene(tmp_path, scene)


@dataclass
class Rig:
    world: World
    connector: Connector
    node: Node
    client: ActionClient


@pytest.fixture
def rig(tmp_path: Path, bridged: Callable[[World], BridgedWorld]) -> Rig:
    bridged_world = bridged(World.from_scene(load_scene(_scene(tmp_path))))
    user = bridged_world.connect()
    client = ActionClient(user, NAME, ACTION)
    assert client.wait_for_server(5)
    assert user.flush(5)
    user.endpoint_stats()  # a barrier: the endpoint holds the client's action topics
    return Rig(bridged_world.world, user, bridged_world.node, client)


def _duration(t: float) -> Any:
    return REG.new("builtin_interfaces/Duration", sec=int(t), nanosec=round((t - int(t)) * 1e9))


def _goal(
    names: list[str],
    points: list[tuple[float, list[float]]],
    goal_tolerance: dict[str, float] | None = None,
    path_tolerance: dict[str, float] | None = None,
    goal_time: float = 0.0,
) -> Any:
    trajectory = REG.new("trajectory_msgs/JointTrajectory", joint_names=names)
    for t, positions in points:
        point = REG.new("trajectory_msgs/JointTrajectoryPoint", positions=np.array(positions))
        point.time_from_start = _duration(t)
        trajectory.points.append(point)

    def tolerances(given: dict[str, float] | None) -> list[Any]:
        return [
            REG.new("control_msgs/JointTolerance", name=n, position=v)
            for n, v in (given or {}).items()
        ]

    return REG.new(
        f"{ACTION}Goal",
        trajectory=trajectory,
        goal_tolerance=tolerances(goal_tolerance),
        path_tolerance=tolerances(path_tolerance),
        goal_time_tolerance=_duration(goal_time),
    )


def test_goal_is_followed_with_feedback_and_state(rig: Rig) -> None:
    states: queue.Queue[Any] = queue.Queue()
    rig.node.subscribe(
        "/arm_left/arm_controller/state", "control_msgs/JointTrajectoryControllerState", states.put
    )
    feedback: list[Any] = []
    goal = rig.client.send_goal(
        _goal(["shoulder", "elbow"], [(0.3, [0.2, -0.3]), (0.6, [0.4, -0.6])]),
        on_feedback=feedback.append,
    )
    assert wait_for(lambda: goal.status == ACTIVE)
    assert goal.wait(5)
    assert (goal.status, goal.result.error_code) == (SUCCEEDED, 0)
    q = rig.world.joint_positions()
    assert q["arm_left/elbow"] == pytest.approx(-0.6, abs=0.01)  # within the goal tolerance
    # Feedback at 20 Hz of sim time over a 0.6 s trajectory: desired, actual and error.
    assert len(feedback) >= 8
    last = feedback[-1]
    assert list(last.joint_names) == ["shoulder", "elbow", "wrist"]
    assert np.allclose(
        np.array(last.error.positions), np.array(last.desired.positions) - last.actual.positions
    )
    assert last.desired.positions[1] == pytest.approx(-0.6, abs=0.05)
    state = states.get(timeout=5)
    assert list(state.joint_names) == ["shoulder", "elbow", "wrist"]
    assert state.header.stamp.sec >= 0


def test_unknown_joints_are_rejected_with_invalid_joints(rig: Rig) -> None:
    goal = rig.client.send_goal(_goal(["shoulder", "grip_a"], [(0.2, [0.1, 0.01])]))
    assert goal.wait(5)
    assert goal.status == REJECTED
    assert goal.result.error_code == -2
    assert "grip_a" in goal.result.error_string
    empty = rig.client.send_goal(_goal(["shoulder"], []))
    assert empty.wait(5)
    assert (empty.status, empty.result.error_code) == (REJECTED, -1)


def test_new_goal_preempts_and_cancel_holds_position(rig: Rig) -> None:
    first = rig.client.send_goal(_goal(["elbow"], [(3.0, [1.0])]))
    assert wait_for(lambda: first.status == ACTIVE)
    second = rig.client.send_goal(_goal(["elbow"], [(3.0, [-1.0])]))
    assert first.wait(5)
    assert first.status == PREEMPTED
    assert wait_for(lambda: second.status == ACTIVE)
    assert wait_for(lambda: rig.world.joint_positions()["arm_left/elbow"] < -0.05)
    second.cancel()
    assert second.wait(5)
    assert second.status == PREEMPTED
    held = rig.world.joint_positions()["arm_left/elbow"]
    time.sleep(0.3)
    assert rig.world.joint_positions()["arm_left/elbow"] == pytest.approx(held, abs=0.02)
    assert held > -0.9  # stopped well before the trajectory's end


def test_path_tolerance_violation_aborts(rig: Rig) -> None:
    # A jump no drive can follow within 0.001 rad.
    goal = rig.client.send_goal(
        _goal(["shoulder"], [(0.05, [1.5]), (1.0, [1.5])], path_tolerance={"shoulder": 0.001})
    )
    assert goal.wait(5)
    assert goal.status == ABORTED
    assert goal.result.error_code == -4
    assert "shoulder" in goal.result.error_string


def test_goal_tolerance_violation_aborts_after_goal_time(rig: Rig) -> None:
    # The wrist cannot reach 3 rad in 0.02 s + 0.05 s within 1e-6 rad.
    goal = rig.client.send_goal(
        _goal(["wrist"], [(0.02, [3.0])], goal_tolerance={"wrist": 1e-6}, goal_time=0.05)
    )
    assert goal.wait(5)
    assert goal.status == ABORTED
    assert goal.result.error_code == -5
    assert "wrist" in goal.result.error_string


def test_command_topic_preempts_the_goal_and_node_client_works(rig: Rig) -> None:
    client = NodeActionClient(rig.node, NAME, ACTION)
    assert client.wait_for_server(5)
    time.sleep(0.2)
    goal = client.send_goal(_goal(["elbow"], [(3.0, [1.0])]))
    assert wait_for(lambda: goal.status == ACTIVE)
    command = rig.node.advertise(
        "/arm_left/arm_controller/command", "trajectory_msgs/JointTrajectory"
    )
    msg = _goal(["elbow"], [(0.3, [-0.4])]).trajectory
    command.publish(msg)
    assert goal.wait(5)
    assert goal.status == PREEMPTED
    assert wait_for(lambda: abs(rig.world.joint_positions()["arm_left/elbow"] + 0.4) < 5e-3)


def test_controller_config_errors_name_the_key(tmp_path: Path) -> None:
    with pytest.raises(SimError, match=r"controllers\.arm_controller\.type"):
        load_scene(_scene(tmp_path, {"type": "effort_controller"}))
    # Found when the scene is built, with or without an endpoint, at the entry's line:
    bad_joint = r"scene\.yaml:\d+: robots\[0\]\.ros\.controllers\.arm_controller\.joints: 'knee'"
    with pytest.raises(SimError, match=bad_joint):
        World.from_scene(load_scene(_scene(tmp_path, {"joints": ["shoulder", "knee"]})))


def test_malformed_goals_are_rejected_not_fatal(rig: Rig) -> None:
    bad = _goal(["shoulder", "elbow"], [(0.2, [0.1, 0.2])])
    bad.trajectory.points[0].positions = np.array([0.1])  # one position for two joints
    goal = rig.client.send_goal(bad)
    assert goal.wait(5)
    assert (goal.status, goal.result.error_code) == (REJECTED, -1)
    assert "1 positions" in goal.result.error_string
    backwards = _goal(["elbow"], [(0.5, [0.1]), (0.2, [0.2])])  # time goes back
    goal = rig.client.send_goal(backwards)
    assert goal.wait(5)
    assert (goal.status, goal.result.error_code) == (REJECTED, -1)
    # The controller still serves.
    fine = rig.client.send_goal(_goal(["elbow"], [(0.2, [0.1])]))
    assert fine.wait(5)
    assert fine.status == SUCCEEDED


def test_a_closed_controller_no_longer_runs_on_reset_or_step(tmp_path: Path) -> None:
    """Closing takes the controller's follower, step and reset callbacks out of the world:
    a reset no longer stops its trajectory (nor aborts a goal), a step no longer follows."""
    world = World.from_scene(load_scene(_scene(tmp_path)))
    with (
        EndpointThread(EndpointOptions(port=0)) as endpoint,
        Connector("127.0.0.1", endpoint.port, ConnectorOptions()).connect(wait=5) as sim,
    ):
        bridge = SimRosBridge(world, sim).start()
        controller = bridge.robots["arm_left"].controllers["arm_controller"]
        assert isinstance(controller, JointTrajectoryController)
        elbow = controller.joints[1]
        trajectory = Trajectory.from_lists([elbow], [1.0], [[0.8]])
        controller.follower.start(trajectory, world.time)
        world.step(1)
        assert world.drives.target(elbow).velocity > 0  # followed while open
        world.reset()
        assert controller.follower.active is None
        bridge.close()
        controller.follower.start(trajectory, world.time)
        world.step(1)
        assert world.drives.target(elbow).velocity == 0.0  # no longer followed
        world.reset()
        assert controller.follower.active is not None  # nothing of it ran on the reset
