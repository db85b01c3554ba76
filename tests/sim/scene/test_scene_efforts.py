"""Effort limits at load (gravity torque check, `effort_limits` policy, per-joint
`force_limit` incl. unlimited) and initial positions clamped into the joint limits."""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
import yaml

from simbridge.errors import SimError
from simbridge.sim.scene import load_scene
from simbridge.sim.urdf import UrdfWarning
from simbridge.sim.world import World
from tests.sim.urdf_samples import inertial, joint, link, robot

# A two-link arm whose URDF efforts are placeholders (1 N m), like the Niryo One's and the
# PR2 shoulders' files: horizontal at zero, so each joint must hold its subtree's weight.
_Y = '<axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="2"/>'
WEAK_ARM = robot(
    link("base", inertial(5.0, 0.05)),
    link("upper", inertial(2.0, 0.02, "0.25 0 0")),
    link("fore", inertial(1.0, 0.01, "0.2 0 0")),
    joint("shoulder", "revolute", "base", "upper", '<origin xyz="0 0 0.5"/>' + _Y),
    joint("elbow", "revolute", "upper", "fore", '<origin xyz="0.5 0 0"/>' + _Y),
    name="weak_arm",
)
# shoulder holds 2 kg at 0.25 m and 1 kg at 0.7 m; elbow 1 kg at 0.2 m
SHOULDER_TORQUE = 9.81 * (2.0 * 0.25 + 1.0 * 0.7)
ELBOW_TORQUE = 9.81 * 1.0 * 0.2


def _world(tmp_path: Path, **robot_keys: Any) -> tuple[World, list[str]]:
    (tmp_path / "arm.urdf").write_text(WEAK_ARM)
    scene = {
        "robots": [{"urdf": "arm.urdf", "armature": 0.01, **robot_keys}],
        "ros": {"enabled": False},
        "strict": robot_keys.pop("strict", False),
    }
    scene["robots"][0].pop("strict", None)
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        world = World.from_scene(load_scene(tmp_path / "scene.yaml"))
    return world, [str(w.message) for w in caught if issubclass(w.category, UrdfWarning)]


def _sag(world: World, seconds: float = 1.0) -> float:
    start = world.joint_positions()
    world.step(round(seconds / world.timestep))
    end = world.joint_positions()
    return max(abs(end[j] - start[j]) for j in start)


def test_gravity_torque_matches_mujoco(tmp_path: Path) -> None:
    from simbridge.sim.scene.efforts import gravity_torques

    world, _ = _world(tmp_path, initial_positions={"shoulder": 0.3, "elbow": -0.7})
    built = world.robot().built
    torques = gravity_torques(
        built.mjcf.robot,
        built.mjcf.inertials,
        built.spec.initial_positions,
        built.spec.base.transform,
        (0.0, 0.0, -9.81),
    )
    data = mujoco.MjData(world.model)
    data.qpos[:] = world.data.qpos
    mujoco.mj_forward(world.model, data)  # qvel = 0: qfrc_bias is gravity alone
    for name in ("shoulder", "elbow"):
        dof = world.model.joint(name).dofadr[0]
        assert torques[name] == pytest.approx(abs(data.qfrc_bias[dof]), rel=1e-9)


def test_urdf_policy_warns_naming_joint_limit_and_torque_and_the_arm_sags(
    tmp_path: Path,
) -> None:
    world, messages = _world(tmp_path)
    urdf = tmp_path / "arm.urdf"
    assert messages == [
        f"{urdf}: robot 'weak_arm' joint 'shoulder': force limit 1 N m (URDF effort) is below "
        f"the {SHOULDER_TORQUE:.3g} N m gravity torque it must hold at the initial pose, so it "
        "will sag (set effort_limits: scale or ignore, or drives.joints.shoulder.force_limit)",
        f"{urdf}: robot 'weak_arm' joint 'elbow': force limit 1 N m (URDF effort) is below "
        f"the {ELBOW_TORQUE:.3g} N m gravity torque it must hold at the initial pose, so it "
        "will sag (set effort_limits: scale or ignore, or drives.joints.elbow.force_limit)",
    ]
    assert _sag(world) > 0.5


@pytest.mark.parametrize("policy", ["scale", "ignore"])
def test_scale_and_ignore_policies_hold_the_arm(tmp_path: Path, policy: str) -> None:
    world, messages = _world(tmp_path, effort_limits=policy)
    assert _sag(world) < 0.01
    limit = world.drives.spec("shoulder").force_limit
    if policy == "ignore":
        assert limit == math.inf
        assert messages == []
    else:  # one factor for all efforts: the shoulder holds twice its gravity torque
        assert limit == pytest.approx(2 * SHOULDER_TORQUE)
        assert world.drives.spec("elbow").force_limit == pytest.approx(2 * SHOULDER_TORQUE)
        assert len(messages) == 1
        assert "effort_limits: scale multiplies the URDF efforts by 23.5" in messages[0]


def test_per_joint_force_limit_overrides_the_policy(tmp_path: Path) -> None:
    world, messages = _world(
        tmp_path,
        drives={"joints": {"shoulder": {"force_limit": "unlimited"}, "elbow": {"force_limit": 50}}},
    )
    assert messages == []
    assert world.drives.spec("shoulder").force_limit == math.inf
    assert world.drives.spec("elbow").force_limit == 50
    assert world.model.actuator_forcelimited[world.model.actuator("shoulder").id] == 0
    assert _sag(world) < 0.01
    world, _ = _world(tmp_path, drives={"joints": {"elbow": {"force_limit": None}}})
    assert world.drives.spec("elbow").force_limit == 1.0  # null: the policy (URDF) again


def test_bad_policy_and_force_limit_words_are_errors(tmp_path: Path) -> None:
    with pytest.raises(SimError, match=r"effort_limits: expected one of urdf, ignore, scale"):
        _world(tmp_path, effort_limits="huge")
    with pytest.raises(SimError, match=r"force_limit: expected a number > 0, 'unlimited'"):
        _world(tmp_path, drives={"default": {"force_limit": "lots"}})


def test_initial_positions_are_clamped_into_limits(tmp_path: Path) -> None:
    world, messages = _world(tmp_path, effort_limits="ignore", initial_positions={"shoulder": 3.0})
    urdf = tmp_path / "arm.urdf"
    assert messages == [
        f"{urdf}: robot 'weak_arm' joint 'shoulder': initial_positions value 3 is outside its "
        "limits [-2, 2]; starting at 2"
    ]
    assert world.joint_positions()["shoulder"] == 2.0
    assert world.drives.target("shoulder").position == 2.0
    assert _sag(world, 0.5) < 0.01  # the drive holds the clamped pose, not fighting the limit
    with pytest.raises(SimError, match=r"initial_positions value 3 is outside.*strict mode"):
        _world(tmp_path, initial_positions={"shoulder": 3.0}, strict=True)


def test_zero_pose_outside_limits_is_clamped_even_in_strict_mode(tmp_path: Path) -> None:
    text = WEAK_ARM.replace('lower="-2" upper="2"', 'lower="0.5" upper="2"')
    (tmp_path / "arm.urdf").write_text(text)
    scene = {
        "robots": [{"urdf": "arm.urdf", "effort_limits": "ignore", "armature": 0.01}],
        "strict": True,
    }
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        world = World.from_scene(load_scene(tmp_path / "scene.yaml"))
    texts = [str(w.message) for w in caught if issubclass(w.category, UrdfWarning)]
    assert len(texts) == 2
    assert "joint 'shoulder': initial position (zero pose) 0 is outside its limits" in texts[0]
    assert np.allclose(list(world.joint_positions().values()), [0.5, 0.5])


def test_unstable_position_gains_are_warned_about_at_load(tmp_path: Path) -> None:
    _, messages = _world(
        tmp_path,
        effort_limits="ignore",
        drives={
            "default": {"stiffness": 10000, "damping": 2},
            "joints": {"elbow": {"damping": 20}},
        },
    )
    assert messages == [
        f"{tmp_path / 'arm.urdf'}: robot 'weak_arm' joint 'shoulder': drive stiffness 10000 "
        "with damping 2 breaks the stability rule timestep * stiffness / damping < 2 "
        "(0.002 * 10000 / 2 = 10); raise damping above 10 or lower the stiffness"
    ]
