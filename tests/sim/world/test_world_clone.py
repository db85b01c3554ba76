"""World.clone: another MjData on the same compiled model, independent state."""

from __future__ import annotations

import numpy as np

from simbridge.gym.tasks import REACH_SCENE
from simbridge.sim import World


def test_clone_shares_the_model_not_the_state() -> None:
    world = World.from_scene(REACH_SCENE)
    twin = world.clone()
    assert twin.model is world.model
    assert twin.data is not world.data
    np.testing.assert_array_equal(twin.data.qpos, world.data.qpos)
    twin.drives.set_position("joint_1", 0.5)
    twin.step(200)
    assert twin.joint_positions(["joint_1"])["joint_1"] > 0.3
    assert abs(world.joint_positions(["joint_1"])["joint_1"]) < 1e-9
    assert world.time == 0.0
    assert twin.drives.target("joint_1").position == 0.5
    assert world.drives.target("joint_1").position == 0.0
