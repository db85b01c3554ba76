"""gripper_action_controller of a namespaced robot through the connector's action client:
reached_goal, stalled at a joint limit (aborted, or succeeded with allow_stalling),
preemption and max_effort."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from simbridge.connector import ActionClient
from simbridge.errors import SimError
from simbridge.messages import default_registry
from simbridge.messages.actionlib import ABORTED, ACTIVE, PREEMPTED, SUCCEEDED
from simbridge.sim.scene import load_scene
from simbridge.sim.world import World
from tests.sim.bridged import BridgedWorld
from tests.sim.worlds import arm_scene
from tests.waiting import wait_for

REG = default_registry()
ACTION = "control_msgs/GripperCommand"
NAME = "/arm/gripper_controller/gripper_cmd"


def _scene(tmp_path: Path, **gripper: Any) -> Path:
    spec = {"type": "gripper_action_controller", "joint": "grip_a", "stall_timeout": 0.2}
    robot = {
        "urdf": "arm.urdf",
        "ros": {
            "namespace": "/arm",
            "controllers": {
                "gripper_controller": {
                    k: v for k, v in {**spec, **gripper}.items() if v is not None
                }
            },
        },
    }
    scene = {"physics": {"gravity": [0, 0, 0]}, "robots": [robot]}
    return arm_scene(tmp_path, scene)


@pytest.fixture
def rig_factory(
    tmp_path: Path, bridged: Callable[[World], BridgedWorld]
) -> Callable[..., tuple[World, ActionClient]]:
    def make(**gripper: Any) -> tuple[World, ActionClient]:
        rig = bridged(World.from_scene(load_scene(_scene(tmp_path, **gripper))))
        client = ActionClient(rig.connect(), NAME, ACTION)
        assert client.wait_for_server(5)
        time.sleep(0.2)
        return rig.world, client

    return make


def _goal(position: float, max_effort: float = 0.0) -> Any:
    command = REG.new("control_msgs/GripperCommand", position=position, max_effort=max_effort)
    return REG.new(f"{ACTION}Goal", command=command)


def test_reaches_the_goal(rig_factory: Callable[..., tuple[World, ActionClient]]) -> None:
    world, client = rig_factory()
    goal = client.send_goal(_goal(0.03, max_effort=5.0))
    assert goal.wait(5)
    assert goal.status == SUCCEEDED
    assert goal.result.reached_goal
    assert not goal.result.stalled
    assert goal.result.position == pytest.approx(0.03, abs=0.01)
    assert world.joint_positions()["arm/grip_a"] == pytest.approx(0.03, abs=0.01)
    assert world.drives.spec("arm/grip_a").force_limit == 5.0  # max_effort


def test_stalls_at_the_joint_limit(rig_factory: Callable[..., tuple[World, ActionClient]]) -> None:
    _world, client = rig_factory()
    goal = client.send_goal(_goal(0.09))  # the joint stops at its 0.05 m limit
    assert goal.wait(5)
    assert goal.status == ABORTED
    assert goal.result.stalled
    assert not goal.result.reached_goal
    assert goal.result.position == pytest.approx(0.05, abs=5e-3)


def test_allow_stalling_succeeds_and_new_goal_preempts(
    rig_factory: Callable[..., tuple[World, ActionClient]],
) -> None:
    _world, client = rig_factory(allow_stalling=True, stall_timeout=30.0)
    slow = client.send_goal(_goal(0.09))
    assert wait_for(lambda: slow.status == ACTIVE)
    fast = client.send_goal(_goal(0.01))
    assert slow.wait(5)
    assert slow.status == PREEMPTED
    assert fast.wait(5)
    assert fast.status == SUCCEEDED


def test_gripper_config_errors(tmp_path: Path) -> None:
    with pytest.raises(SimError, match=r"gripper_controller: missing key 'joint'"):
        load_scene(_scene(tmp_path, joint=None))
    with pytest.raises(SimError, match=r"gripper_controller: unknown key 'stall'"):
        load_scene(_scene(tmp_path, stall=1))
