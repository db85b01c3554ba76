"""The shipped Niryo One URDF: names, Niryo's limits, primitive inertias, gravity holding."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

from simbridge.assets import asset_path, robot_names, robot_urdf

ARM_JOINTS = [f"joint_{i}" for i in range(1, 7)]
# Niryo One (hardware v2) position limits from niryo_one_description.
NIRYO_LIMITS = {
    "joint_1": (-3.05433, 3.05433),
    "joint_2": (-1.91986, 0.640187),
    "joint_3": (-1.397485, math.pi / 2),
    "joint_4": (-3.05433, 3.05433),
    "joint_5": (-1.74533, 1.91986),
    "joint_6": (-2.57436, 2.57436),
}


@pytest.fixture(scope="module")
def root() -> ET.Element:
    return ET.parse(robot_urdf("niryo_one")).getroot()


def test_lookup_helpers() -> None:
    assert "niryo_one" in robot_names()
    assert robot_urdf().name == "niryo_one.urdf"
    assert asset_path("robots/niryo_one.urdf") == robot_urdf("niryo_one")
    with pytest.raises(FileNotFoundError, match="niryo_one"):
        robot_urdf("ur5")
    with pytest.raises(FileNotFoundError, match=r"nothing\.urdf"):
        asset_path("robots/nothing.urdf")


def test_names_follow_niryo_description(root: ET.Element) -> None:
    links = {link.get("name") for link in root.iter("link")}
    assert {
        "base_link",
        "shoulder_link",
        "arm_link",
        "elbow_link",
        "forearm_link",
        "wrist_link",
        "hand_link",
        "tool_link",
        "grasp_link",
    } <= links
    revolute = [j.get("name") for j in root.iter("joint") if j.get("type") == "revolute"]
    assert revolute == ARM_JOINTS


def test_limits_are_niryos(root: ET.Element) -> None:
    for joint in root.iter("joint"):
        name = joint.get("name")
        if name not in NIRYO_LIMITS:
            continue
        limit = joint.find("limit")
        assert limit is not None
        assert float(limit.get("lower", "nan")) == pytest.approx(NIRYO_LIMITS[name][0])
        assert float(limit.get("upper", "nan")) == pytest.approx(NIRYO_LIMITS[name][1])
        assert 0.5 <= float(limit.get("velocity", "0")) <= 3.0


def test_gripper_fingers_mimic(root: ET.Element) -> None:
    joints = {j.get("name"): j for j in root.iter("joint")}
    left, right = joints["left_finger_joint"], joints["right_finger_joint"]
    assert left.get("type") == right.get("type") == "prismatic"
    mimic = right.find("mimic")
    assert mimic is not None
    assert mimic.get("joint") == "left_finger_joint"


def _primitive_inertia(mass: float, geometry: ET.Element) -> np.ndarray:
    shape = geometry[0]
    if shape.tag == "box":
        x, y, z = (float(v) for v in shape.get("size", "").split())
        return mass / 12 * np.array([y * y + z * z, x * x + z * z, x * x + y * y])
    assert shape.tag == "cylinder"
    r, h = float(shape.get("radius", "nan")), float(shape.get("length", "nan"))
    side = mass * (3 * r * r + h * h) / 12
    return np.array([side, side, mass * r * r / 2])


def test_inertias_are_those_of_the_primitives(root: ET.Element) -> None:
    checked = 0
    for link in root.iter("link"):
        inertial, collision = link.find("inertial"), link.find("collision")
        if inertial is None:
            continue
        assert collision is not None
        c_origin, i_origin = collision.find("origin"), inertial.find("origin")
        assert c_origin is not None
        assert i_origin is not None
        assert c_origin.attrib == i_origin.attrib, link.get("name")
        mass_el, inertia_el, geometry = (
            inertial.find("mass"),
            inertial.find("inertia"),
            collision.find("geometry"),
        )
        assert mass_el is not None
        assert inertia_el is not None
        assert geometry is not None
        expected = _primitive_inertia(float(mass_el.get("value", "nan")), geometry)
        actual = np.array([float(inertia_el.get(k, "nan")) for k in ("ixx", "iyy", "izz")])
        np.testing.assert_allclose(actual, expected, rtol=1e-3, err_msg=link.get("name"))
        checked += 1
    assert checked == 10


def test_mujoco_loads_it_with_all_frames() -> None:
    model = mujoco.MjModel.from_xml_path(str(robot_urdf()))
    for name in ("tool_link", "grasp_link", "gripper_base_link"):
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name) >= 0
    assert model.neq == 1  # the finger mimic
    assert model.nq == 8


def test_effort_limits_hold_the_stretched_arm_with_payload(root: ET.Element) -> None:
    """Gravity torques, arm horizontal, 0.1 kg at the grasp point: below the limits."""
    model = mujoco.MjModel.from_xml_path(str(robot_urdf()))
    grasp = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "grasp_link")
    model.body_mass[grasp] = 0.1
    data = mujoco.MjData(model)
    efforts = {
        j.get("name"): float(j.find("limit").get("effort", "0"))  # type: ignore[union-attr]
        for j in root.iter("joint")
        if j.get("name") in NIRYO_LIMITS
    }
    worst = dict.fromkeys(ARM_JOINTS, 0.0)
    # joint_2 = -pi/2 lays the arm horizontal; joint_3/5 sweep the rest of the chain.
    for q3 in (0.0, 1.5):
        for q5 in (-1.5, 0.0, 1.5):
            data.qpos[:] = [0.0, -math.pi / 2 + 0.05, q3, 0.0, q5, 0.0, 0.02, 0.02]
            data.qvel[:] = 0.0
            data.qacc[:] = 0.0
            mujoco.mj_inverse(model, data)
            for i, name in enumerate(ARM_JOINTS):
                worst[name] = max(worst[name], abs(float(data.qfrc_inverse[i])))
    assert worst["joint_2"] > 1.0  # the check is meaningful: the shoulder carries real load
    for name in ARM_JOINTS:
        assert worst[name] < 0.6 * efforts[name], (name, worst[name], efforts[name])
