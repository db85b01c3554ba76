"""joint_group_{position,velocity,effort}_controller of a namespaced robot on the local bus,
and the rule that one joint belongs to one controller."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from simbridge.connector import Connector, ConnectorOptions
from simbridge.endpoint import Node
from simbridge.errors import SimError
from simbridge.messages import default_registry
from simbridge.sim.ros import GroupCommandController, SimRosBridge
from simbridge.sim.scene import load_scene
from simbridge.sim.world import World
from tests.sim.bridged import BridgedWorld
from tests.sim.worlds import arm_scene
from tests.waiting import wait_for

REG = default_registry()


def _scene(tmp_path: Path, controllers: dict[str, Any]) -> Path:
    robot = {
        "urdf": "arm.urdf",
        "ros": {
            "namespace": "/arm",
            "commands": {"position": False, "velocity": False},
            "controllers": controllers,
        },
    }
    scene = {"physics": {"gravity": [0, 0, 0]}, "robots": [robot]}
    return arm_scene(tmp_path, scene)


CONTROLLERS = {
    "arm_position": {"type": "joint_group_position_controller", "joints": ["shoulder", "elbow"]},
    "wrist_velocity": {"type": "joint_group_velocity_controller", "joints": ["wrist"]},
    "finger_effort": {"type": "joint_group_effort_controller", "joints": ["grip_a"]},
}


@pytest.fixture
def rig(
    tmp_path: Path, bridged: Callable[[World], BridgedWorld]
) -> tuple[World, Node, SimRosBridge]:
    rig = bridged(World.from_scene(load_scene(_scene(tmp_path, CONTROLLERS))))
    return rig.world, rig.node, rig.bridge


def _array(*values: float) -> Any:
    return REG.new("std_msgs/Float64MultiArray", data=np.array(values))


def test_position_velocity_and_effort_groups(rig: tuple[World, Node, SimRosBridge]) -> None:
    world, node, bridge = rig
    q, v = world.joint_positions, world.joint_velocities
    node.advertise("/arm/arm_position/command", "std_msgs/Float64MultiArray").publish(
        _array(0.3, -0.2)
    )
    assert wait_for(
        lambda: abs(q()["arm/shoulder"] - 0.3) < 2e-3 and abs(q()["arm/elbow"] + 0.2) < 2e-3
    )
    node.advertise("/arm/wrist_velocity/command", "std_msgs/Float64MultiArray").publish(_array(2.0))
    assert wait_for(lambda: abs(v()["arm/wrist"] - 2.0) < 0.02)
    effort = node.advertise("/arm/finger_effort/command", "std_msgs/Float64MultiArray")
    effort.publish(_array(5.0))  # pushes the finger open against its limit
    assert wait_for(lambda: q()["arm/grip_a"] > 0.045)
    effort.publish(_array(1.0, 2.0))
    controller = bridge.robots["arm"].controllers["finger_effort"]
    assert isinstance(controller, GroupCommandController)
    assert wait_for(lambda: bool(controller.errors))
    assert "2 values for 1 joints (grip_a)" in controller.errors[0]


def test_a_joint_belongs_to_one_controller(tmp_path: Path) -> None:
    overlapping = {
        **CONTROLLERS,
        "wrist_position": {"type": "joint_group_position_controller", "joints": ["wrist"]},
    }
    world = World.from_scene(load_scene(_scene(tmp_path, overlapping)))
    with pytest.raises(SimError, match="joint 'wrist' is claimed by controllers 'wrist_"):
        SimRosBridge(world, Connector("127.0.0.1", 9, ConnectorOptions()))
