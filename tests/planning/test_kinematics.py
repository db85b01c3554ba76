"""Forward kinematics against hand-computed poses, Jacobian, limits and collision checks."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.assets import robot_urdf
from simbridge.errors import PlanningError
from simbridge.planning import ArmKinematics, ArmSpec, Pose, niryo_one_arm

# Niryo One link lengths (m)
SHOULDER_Z = 0.103 + 0.080  # joint_2 height above base_link
ARM = 0.210
ELBOW_X, ELBOW_Y = 0.0415, 0.030
FOREARM = 0.180
WRIST_X, WRIST_Y = 0.0164, -0.0055
HAND_TOOL = 0.0073
REACH = ELBOW_X + FOREARM + WRIST_X + HAND_TOOL  # forearm direction, joint_3 to tool
RISE = ELBOW_Y + WRIST_Y  # perpendicular offset, joint_3 to tool


def _rz(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


def _ry(a: float) -> np.ndarray:
    return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])


HAND_COMPUTED = [
    # all zero: arm straight up, forearm and tool pointing forward (+x)
    ([0, 0, 0, 0, 0, 0], [REACH, 0, SHOULDER_Z + ARM + RISE], np.eye(3)),
    # joint_1 turns everything about z
    (
        [math.pi / 2, 0, 0, 0, 0, 0],
        [0, REACH, SHOULDER_Z + ARM + RISE],
        _rz(math.pi / 2),
    ),
    # joint_2 = -90 deg lays the arm forward; the forearm then points down
    (
        [0, -math.pi / 2, 0, 0, 0, 0],
        [ARM + RISE, 0, SHOULDER_Z - REACH],
        _ry(math.pi / 2),
    ),
    # joint_3 = +90 deg ("straight up" in Niryo's SRDF): forearm points up
    ([0, 0, math.pi / 2, 0, 0, 0], [-RISE, 0, SHOULDER_Z + ARM + REACH], _ry(-math.pi / 2)),
    # joint_5 = +90 deg pitches the hand up at the end of the forearm
    (
        [0, 0, 0, 0, math.pi / 2, 0],
        [
            ELBOW_X + FOREARM - WRIST_Y,
            0,
            SHOULDER_Z + ARM + ELBOW_Y + WRIST_X + HAND_TOOL,
        ],
        _ry(-math.pi / 2),
    ),
    # joint_4 and joint_6 roll about the (forward) forearm/tool axis: position unchanged
    (
        [0, 0, 0, 0.7, 0, -0.3],
        [
            ELBOW_X + FOREARM + WRIST_X + HAND_TOOL,
            -WRIST_Y * math.sin(0.7),
            SHOULDER_Z + ARM + ELBOW_Y + WRIST_Y * math.cos(0.7),
        ],
        np.array(
            [[1, 0, 0], [0, math.cos(0.4), -math.sin(0.4)], [0, math.sin(0.4), math.cos(0.4)]]
        ),
    ),
]


@pytest.mark.parametrize(("q", "position", "rotation"), HAND_COMPUTED)
def test_forward_kinematics_matches_hand_computation(
    kinematics: ArmKinematics, q: list[float], position: list[float], rotation: np.ndarray
) -> None:
    pose = kinematics.forward(np.array(q, dtype=float))
    np.testing.assert_allclose(pose.position, position, atol=1e-9)
    np.testing.assert_allclose(pose.rotation, rotation, atol=1e-9)


def test_grasp_frame_is_5cm_along_the_approach_axis() -> None:
    model = mujoco.MjModel.from_xml_path(str(robot_urdf()))
    tool = ArmKinematics(model, niryo_one_arm())
    grasp = ArmKinematics(model, niryo_one_arm(tool_frame="grasp_link"))
    q = np.array([0.3, -0.5, 0.2, 0.4, -0.6, 0.8])
    t, g = tool.forward(q), grasp.forward(q)
    np.testing.assert_allclose(g.position, t.position + 0.05 * t.rotation[:, 0], atol=1e-12)


joint_values = st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=6, max_size=6)


@settings(max_examples=40, deadline=None)
@given(joint_values)
def test_jacobian_matches_finite_differences(
    kinematics: ArmKinematics, fractions: list[float]
) -> None:
    k = kinematics
    q = k.lower + (np.array(fractions) + 1) / 2 * (k.upper - k.lower)
    k.set_configuration(q)
    jac = k.jacobian()
    base = k.forward(q)
    eps = 1e-6
    for i in range(6):
        dq = np.zeros(6)
        dq[i] = eps
        moved = k.forward(q + dq)
        np.testing.assert_allclose((moved.position - base.position) / eps, jac[:3, i], atol=1e-5)
        # angular velocity from R' R^T
        skew = (moved.rotation - base.rotation) / eps @ base.rotation.T
        omega = np.array([skew[2, 1], skew[0, 2], skew[1, 0]])
        np.testing.assert_allclose(omega, jac[3:, i], atol=1e-5)


def test_limits_are_read_from_the_model(kinematics: ArmKinematics) -> None:
    np.testing.assert_allclose(kinematics.lower[:3], [-3.05433, -1.91986, -1.397485])
    np.testing.assert_allclose(kinematics.upper[:3], [3.05433, 0.640187, math.pi / 2])
    kinematics.check_limits(np.zeros(6), "zeros")
    with pytest.raises(PlanningError, match=r"joint_2 = 1\.0000 rad is outside its limits"):
        kinematics.check_limits(np.array([0, 1.0, 0, 0, 0, 0]), "start")
    with pytest.raises(PlanningError, match="expected 6 finite joint values"):
        kinematics.check_limits(np.zeros(5), "start")


def test_collisions_with_table_and_self(kinematics: ArmKinematics) -> None:
    assert not kinematics.in_collision(np.zeros(6))
    assert kinematics.contacts(np.zeros(6)) == []
    # arm laid forward and down: the gripper drives into the table
    down = np.array([0, -1.5, 0.3, 0, 0, 0])
    assert kinematics.forward(down).position[2] < 0
    assert kinematics.in_collision(down)
    names = {n for c in kinematics.contacts(down) for n in (c.first, c.second)}
    assert "table" in names
    # the wrist folded back onto the forearm collides with itself
    folded = np.array([0, 0, 0, 0, 1.91, 0])
    contacts = kinematics.contacts(folded)
    assert contacts
    assert all("table" not in (c.first, c.second) for c in contacts)


def test_free_bodies_are_ignored() -> None:
    """A free cube overlapping the gripper is the sim's business, not a planning collision."""
    spec = mujoco.MjSpec.from_file(str(robot_urdf()))
    cube = spec.worldbody.add_body(name="cube", pos=[0.27, 0, 0.4175])
    cube.add_freejoint()
    cube.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.025] * 3)
    k = ArmKinematics(spec.compile(), niryo_one_arm())
    assert not k.in_collision(np.zeros(6))


def test_bad_names_are_reported() -> None:
    model = mujoco.MjModel.from_xml_path(str(robot_urdf()))
    with pytest.raises(PlanningError, match=r"no joint 'elbow'.*joint_1"):
        ArmKinematics(model, ArmSpec(("elbow",), "tool_link", "base_link"))
    with pytest.raises(PlanningError, match="tool frame 'flange'"):
        ArmKinematics(model, ArmSpec(("joint_1",), "flange", "base_link"))


def test_poses_are_relative_to_the_base_frame() -> None:
    spec = mujoco.MjSpec.from_file(str(robot_urdf()))
    spec.body("base_link").pos = [1.0, 2.0, 0.5]
    k = ArmKinematics(spec.compile(), niryo_one_arm())
    pose = k.forward(np.zeros(6))
    np.testing.assert_allclose(pose.position, HAND_COMPUTED[0][1], atol=1e-9)
    world_pos, _ = k.to_world(Pose(pose.position, pose.orientation))
    np.testing.assert_allclose(world_pos, np.array(HAND_COMPUTED[0][1]) + np.array([1.0, 2.0, 0.5]))


def test_same_kinematics_through_the_simulators_urdf_builder() -> None:
    """The planner works on the sim's MjModel (simbridge.sim.urdf) exactly as on MuJoCo's own."""
    from simbridge.sim.urdf import MjcfOptions, load_urdf, robot_to_mjcf

    doc, _ = robot_to_mjcf(load_urdf(robot_urdf()), MjcfOptions(self_collision=True))
    ours = ArmKinematics(doc.compile(), niryo_one_arm())
    mujocos = ArmKinematics(mujoco.MjModel.from_xml_path(str(robot_urdf())), niryo_one_arm())
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = rng.uniform(ours.lower, ours.upper)
        a, b = ours.forward(q), mujocos.forward(q)
        np.testing.assert_allclose(a.position, b.position, atol=1e-9)
        np.testing.assert_allclose(a.rotation, b.rotation, atol=1e-9)
        assert ours.in_collision(q) == mujocos.in_collision(q)
