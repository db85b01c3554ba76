"""TF from MuJoCo's body poses (the fast path) agrees with `Transform` algebra."""

from __future__ import annotations

import warnings

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.assets import robot_urdf
from simbridge.sim.ros.state_publisher import relative_poses
from simbridge.sim.scene import parse_scene
from simbridge.sim.world import World

ARM = [f"joint_{i}" for i in range(1, 7)]


def _world(fixed: bool) -> World:
    urdf = robot_urdf("niryo_one")
    robot = {
        "urdf": str(urdf),
        "fixed_base": fixed,
        "base": {"xyz": [0.1, -0.2, 0.3], "rpy": [0.3, -0.2, 2.5]},
    }
    with warnings.catch_warnings():  # the gripper's zero pose is outside its limits
        warnings.simplefilter("ignore")
        return World.from_scene(parse_scene({"robots": [robot]}, urdf.parent))


WORLDS = {fixed: _world(fixed) for fixed in (True, False)}


@settings(max_examples=40, deadline=None)
@given(
    fixed=st.booleans(),
    angles=st.lists(st.floats(-3.0, 3.0), min_size=6, max_size=6),
    steps=st.integers(0, 30),
)
def test_relative_poses_match_transforms(fixed: bool, angles: list[float], steps: int) -> None:
    world = WORLDS[fixed]
    world.set_joint_positions(dict(zip(ARM, angles, strict=True)))
    world.step(steps)  # a floating base falls and tumbles: any orientation
    robot = world.robot()
    links = [(robot.prefix + robot.robot.root, None)] + [
        (robot.prefix + child, robot.prefix + parent) for parent, child, _ in robot.tree_edges()
    ]
    ids = [
        (0 if parent is None else world.model.body(parent).id, world.model.body(child).id)
        for child, parent in links
    ]
    world.refresh()
    got = relative_poses(world.data, ids)
    for (child, parent), pose in zip(links, got, strict=True):
        rel = world.link_pose(child)
        if parent is not None:
            rel = world.link_pose(parent).inverse() @ rel
        assert pose[:3] == pytest.approx(rel.xyz, abs=1e-9)
        assert pose[6] >= 0.0
        assert pose[3:] == pytest.approx(rel.quat_xyzw, abs=1e-6)
