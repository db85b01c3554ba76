"""Every YAML example in docs/scenes.md loads and runs stably (so the documentation stays true)."""

from __future__ import annotations

import math
import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh
import yaml

from simbridge.sim.scene import parse_scene
from simbridge.sim.world import World

DOCS = Path(__file__).resolve().parents[3] / "docs" / "scenes.md"


MY_ROBOT_XACRO = """<robot name="my_robot" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="gripper" default="false"/>
  <link name="base_link"/>
  <link name="arm"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
</robot>
"""


def _docs_tree(tmp_path: Path) -> Path:
    """A copy of the files the examples name, laid out as the docs assume."""
    repo = DOCS.parents[1]
    docs = tmp_path / "docs"
    (docs / "meshes").mkdir(parents=True)
    (tmp_path / "src").symlink_to(repo / "src")
    (tmp_path / "my_ws" / "src").mkdir(parents=True)
    trimesh.creation.box(extents=(40, 20, 5)).export(str(docs / "meshes" / "bracket.stl"))
    shutil.copy(repo / "src/simbridge/assets/robots/niryo_one.urdf", docs)
    (docs / "my_robot.urdf.xacro").write_text(MY_ROBOT_XACRO)
    return docs


def _run(world: World, seconds: float, move: bool) -> dict[str, float]:
    """Step `seconds`, moving every arm joint along a sine (and the gripper) if `move`;
    the largest speed (after 0.2 s) and limit overshoot per joint."""
    model, data = world.model, world.data
    driven = world.drives.joints
    worst: dict[str, float] = {}
    for k in range(round(seconds / world.timestep)):
        t = k * world.timestep
        if move:
            for name in driven:
                if name.startswith("joint_") and name not in ("joint_2", "joint_3"):
                    world.drives.set_position(name, 0.5 * math.sin(2 * t), math.cos(2 * t))
            if "left_finger_joint" in driven:
                opening = 0.002 + 0.033 * (0.5 + 0.5 * math.sin(3 * t))
                world.drives.set_position("left_finger_joint", opening, 0.0)
        world.step(1)
        assert np.all(np.isfinite(data.qpos)), f"NaN at t={t}"
        if t < 0.2:
            continue
        for name in world.joint_names():
            jnt = model.joint(name)
            speed = abs(float(data.qvel[jnt.dofadr[0]]))
            over = 0.0
            if model.jnt_limited[jnt.id]:
                low, high = model.jnt_range[jnt.id]
                q = float(data.qpos[jnt.qposadr[0]])
                over = max(low - q, q - high, 0.0)
            worst[name] = max(worst.get(name, 0.0), speed)
            worst[f"{name}/over"] = max(worst.get(f"{name}/over", 0.0), over)
    return worst


def test_every_documented_example_loads_and_runs_stably(tmp_path: Path) -> None:
    docs = _docs_tree(tmp_path)
    blocks = re.findall(r"```yaml\n(.*?)```", DOCS.read_text(), flags=re.DOTALL)
    assert len(blocks) == 9
    for index, block in enumerate(blocks):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            world = World.from_scene(parse_scene(yaml.safe_load(block), docs))
        unstable = [str(w.message) for w in caught if "stability rule" in str(w.message)]
        assert unstable == [], f"example {index}"
        if index == 0:  # the complete example: its values, held still, then a trajectory
            assert world.drives.spec("joint_6").force_limit == 5
            assert world.drives.spec("joint_1").force_limit == 10  # the URDF's effort limit
            world.step(1000)
            positions = world.joint_positions()
            assert positions["joint_2"] == pytest.approx(-0.3, abs=5e-3)
            assert positions["joint_3"] == pytest.approx(0.6, abs=5e-3)
            assert world.link_pose("cube").xyz[2] == pytest.approx(0.215, abs=2e-3)
            worst = _run(world, 3.0, move=True)
            # commanded at most 1 rad/s: no chatter (was 30-55 rad/s without armature)
            for joint in ("joint_1", "joint_4", "joint_5", "joint_6"):
                assert worst[joint] < 1.5, (joint, worst[joint])
            assert worst["right_finger_joint/over"] < 1e-3  # the mimic finger stays in range
        elif "diffbot.urdf" in block:  # the diff-drive base: drive forward, stay upright
            base = world.robot().robot.root
            for _ in range(1000):
                world.drives.set_velocity("left_wheel_joint", 8.0)
                world.drives.set_velocity("right_wheel_joint", 8.0)
                world.step(1)
            pose = world.link_pose(base)
            assert pose.rotation[2, 2] > 0.95  # its z axis still points up
            assert pose.xyz[0] > 0.3  # ~0.4 m/s for 2 s, less the ramp up
            assert pose.xyz[2] == pytest.approx(0.05, abs=0.02)
        else:
            if "arm_left" in block:  # two copies of one URDF, each with its own ros: block
                assert sorted(world.robots) == ["arm_left", "arm_right"]
                assert "arm_right/joint_1" in world.joint_names()
            if "pallet_controller" in block:  # the line scene: an arm and the conveyor
                assert sorted(world.robots) == ["arm_in", "conveyor"]
                assert "conveyor/pallet_joint" in world.drives.joints
            worst = _run(world, 1.0, move=False)
            speeds = [v for k, v in worst.items() if not k.endswith("/over")]
            assert max(speeds, default=0.0) < 0.1  # the labelled camera's example has no joints


def test_run_scene_headless_without_endpoint(tmp_path: Path) -> None:
    from simbridge.sim.runner import run_scene
    from tests.sim.urdf_samples import GRAVITY_ARM

    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    (tmp_path / "scene.yaml").write_text("robots: [{urdf: arm.urdf}]\n")
    stats = run_scene(tmp_path / "scene.yaml", duration=0.1, realtime_factor=0)
    assert stats.steps == 50
    assert stats.sim_time == pytest.approx(0.1)
