"""Joint drives: position targets under gravity, holding still, velocity and effort modes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from simbridge.errors import SimError
from simbridge.sim.control import DriveMode, DriveSpec
from tests.sim.worlds import arm_world


def test_position_drives_reach_targets_against_gravity(tmp_path: Path) -> None:
    world = arm_world(tmp_path)
    targets = {"shoulder": -0.6, "elbow": 0.9, "wrist": 1.2, "grip_a": 0.03}
    for joint, value in targets.items():
        world.drives.set_position(joint, value)
    world.step(1500)  # 3 s
    reached = world.joint_positions()
    for joint, value in targets.items():
        assert reached[joint] == pytest.approx(value, abs=2e-3), joint
    # the mimic finger mirrors the leader through the equality constraint
    assert reached["grip_b"] == pytest.approx(-reached["grip_a"], abs=2e-3)


def test_default_drives_hold_an_arm_still_under_gravity(tmp_path: Path) -> None:
    world = arm_world(tmp_path, robot={"initial_positions": {"shoulder": -0.7, "elbow": 0.4}})
    start = world.joint_positions()
    samples = []
    for _ in range(300):  # 3 s, sampled every 10 ms
        world.step(5)
        samples.append(list(world.joint_velocities().values()))
    end = world.joint_positions()
    assert end["shoulder"] == pytest.approx(start["shoulder"], abs=1e-3)
    assert end["elbow"] == pytest.approx(start["elbow"], abs=1e-3)
    late = np.abs(np.array(samples[100:]))  # after the first second: no jitter at all
    assert late.max() < 1e-4
    # gravity really loads the shoulder: the drive pushes back
    assert abs(world.joint_efforts()["shoulder"]) > 1.0


def test_velocity_mode_tracks_target_velocity(tmp_path: Path) -> None:
    world = arm_world(
        tmp_path, robot={"drives": {"joints": {"wrist": {"mode": "velocity", "damping": 50}}}}
    )
    world.drives.set_velocity("wrist", 2.0)
    world.step(500)
    assert world.joint_velocities()["wrist"] == pytest.approx(2.0, rel=1e-3)
    q0 = world.joint_positions()["wrist"]
    world.step(250)
    assert world.joint_positions()["wrist"] - q0 == pytest.approx(1.0, rel=1e-2)


def test_effort_mode_accelerates_as_newton_says(tmp_path: Path) -> None:
    world = arm_world(
        tmp_path,
        physics={"gravity": [0, 0, 0]},
        robot={"drives": {"joints": {"wrist": {"mode": "effort"}}}, "armature": 0.002},
    )
    torque = 0.01
    world.drives.set_effort("wrist", torque)
    world.step(250)  # 0.5 s
    # wrist turns the 'spin' link plus two fingers about X: I = 0.001 + 2 * 1e-5 (at the axis),
    # plus the joint's armature (rotor inertia)
    alpha = torque / (0.001 + 2e-5 + 0.002)
    assert world.joint_positions()["wrist"] == pytest.approx(0.5 * alpha * 0.25, rel=2e-2)
    assert world.joint_efforts()["wrist"] == pytest.approx(torque)


def test_force_limit_caps_the_drive(tmp_path: Path) -> None:
    world = arm_world(tmp_path, robot={"drives": {"joints": {"shoulder": {"force_limit": 2.0}}}})
    world.drives.set_position("shoulder", -1.5)
    world.step(100)
    assert abs(world.joint_efforts()["shoulder"]) <= 2.0 + 1e-9
    # the URDF effort limit (200) applies where the scene sets none
    assert world.drives.spec("elbow").force_limit == 200.0


def test_switching_modes_at_run_time(tmp_path: Path) -> None:
    world = arm_world(tmp_path, physics={"gravity": [0, 0, 0]})
    world.drives.set_spec("wrist", DriveSpec(DriveMode.NONE))
    world.step(10)
    assert world.joint_efforts()["wrist"] == 0.0
    world.drives.set_spec("wrist", DriveSpec(DriveMode.POSITION, 100.0, 10.0))
    world.drives.set_position("wrist", 0.5)
    world.step(1000)
    assert world.joint_positions()["wrist"] == pytest.approx(0.5, abs=1e-3)


def test_targets_are_clamped_to_limits_and_undriven_joints_rejected(tmp_path: Path) -> None:
    world = arm_world(tmp_path)
    world.drives.set_position("elbow", 10.0)
    assert world.drives.target("elbow").position == 3.0
    with pytest.raises(SimError, match="joint 'grip_b' has no drive"):
        world.drives.set_position("grip_b", 0.0)
    with pytest.raises(SimError, match="stiffness must be finite"):
        DriveSpec(stiffness=math.inf)


def test_position_controls_of_many_worlds_into_given_arrays(tmp_path: Path) -> None:
    world = arm_world(
        tmp_path,
        robot={"drives": {"joints": {"wrist": {"mode": "effort"}}}},
    )
    drives = world.drives
    drives.set_effort("wrist", 0.25)
    actuators = drives.actuators(["shoulder", "elbow", "wrist"])
    positions = np.array([[0.5, 10.0, 1.0], [-9.0, 0.1, -1.0]])  # two worlds, out of limits too
    clamped, ctrl = drives.position_controls(actuators, positions)
    assert clamped[0, 1] == 3.0  # elbow's upper limit
    assert (ctrl[:, 2] == 0.25).all()  # the effort drive keeps its effort
    # the same bits written into views of the caller's arrays, the input untouched
    before = positions.copy()
    targets, controls = np.full((2, 5), np.nan), np.full((2, 5), np.nan)
    drives.position_controls_into(actuators, positions, targets[:, 1:4], controls[:, 1:4])
    np.testing.assert_array_equal(targets[:, 1:4], clamped)
    np.testing.assert_array_equal(controls[:, 1:4], ctrl)
    assert np.isnan(targets[:, [0, 4]]).all()
    assert np.isnan(controls[:, [0, 4]]).all()
    np.testing.assert_array_equal(positions, before)
