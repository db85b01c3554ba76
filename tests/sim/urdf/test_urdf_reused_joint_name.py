"""A joint name used twice for different child links, as in the Unity Robotics Hub's
niryo_one.urdf (`hand_tool_joint`: hand_link -> tool_link, then tool_link -> gripper_base).
Unity's importer builds the tree from child links and loads the whole arm with its gripper;
simbridge keeps the second joint under a unique name, with a warning naming file and line.
The asset is our own small robot with that shape."""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest

from simbridge.cli import main
from simbridge.errors import UrdfError
from simbridge.sim.urdf import (
    MjcfOptions,
    Robot,
    UrdfWarning,
    forward_kinematics,
    load_urdf,
    robot_to_mjcf,
)

ASSET = Path(__file__).parents[1] / "assets" / "unity_niryo_shape.urdf"
ARM = [f"joint_{i}" for i in range(1, 7)]
FINGERS = ["left_gripper_joint", "right_gripper_joint"]


def _lines_naming(name: str) -> list[int]:
    """1-based lines of the asset that define a joint called `name`."""
    text = ASSET.read_text().splitlines()
    return [n for n, line in enumerate(text, 1) if f'<joint name="{name}"' in line]


def _load() -> tuple[Robot, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = load_urdf(ASSET)
    return robot, [str(w.message) for w in caught if issubclass(w.category, UrdfWarning)]


def test_second_joint_is_kept_under_a_unique_name_with_a_warning() -> None:
    first, second = _lines_naming("hand_tool_joint")
    robot, messages = _load()
    assert messages == [
        f"{ASSET}:{second}: joint 'hand_tool_joint' is defined twice for different links "
        f"(line {first}: hand_link -> tool_link; this one: tool_link -> gripper_base); "
        "keeping both, this one as 'hand_tool_joint_2'"
    ]
    assert robot.root == "world"
    kept = robot.joints["hand_tool_joint"]
    renamed = robot.joints["hand_tool_joint_2"]
    assert (kept.parent, kept.child, kept.origin.xyz) == ("hand_link", "tool_link", (0.02, 0, 0))
    assert (renamed.parent, renamed.child, renamed.origin.xyz) == (
        "tool_link",
        "gripper_base",
        (0.01, 0, 0),
    )
    declared = {e.get("name") for e in ET.parse(ASSET).getroot().iter("link")}
    assert set(robot.links_depth_first()) == declared  # every link is in the one tree


def test_strict_mode_refuses_the_reused_name() -> None:
    _, second = _lines_naming("hand_tool_joint")
    with pytest.raises(
        UrdfError,
        match=rf"^{ASSET}:{second}: joint 'hand_tool_joint' is defined twice for different "
        r"links .*\(strict mode\)$",
    ):
        load_urdf(ASSET, strict=True)


def test_urdf_check_shows_the_gripper_and_strict_fails(capsys: pytest.CaptureFixture[str]) -> None:
    _, second = _lines_naming("hand_tool_joint")
    assert main(["urdf", "check", str(ASSET)]) == 0
    out = capsys.readouterr().out
    assert "root Link: world has 1 child(ren)" in out
    assert "hand_tool_joint_2 [fixed] tool_link -> gripper_base" in out
    for finger in ("left_gripper", "right_gripper"):
        assert f"child(10):  {finger}" in out
    assert f"warnings (1):\n  {ASSET}:{second}: joint 'hand_tool_joint'" in out

    assert main(["urdf", "check", "--strict", str(ASSET)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.startswith(
        f"simbridge: error: {ASSET}:{second}: joint 'hand_tool_joint' is defined twice"
    )


def test_arm_and_both_fingers_move_in_mujoco() -> None:
    """Position servos on the six arm joints and both fingers: each joint gets most of the
    way to its target, the gripper rides on the arm, and every body sits where the URDF's
    forward kinematics (second hand_tool_joint included) puts it."""
    robot, _ = _load()
    doc, mapped = robot_to_mjcf(robot, MjcfOptions(armature=0.01))
    actuators = doc.section("actuator")
    targets = dict(zip(ARM, (0.8, -0.5, 0.6, 0.7, -0.6, 0.9), strict=True))
    targets.update(dict.fromkeys(FINGERS, 0.015))
    for joint in targets:
        kp = 100.0 if joint in ARM else 50.0
        ET.SubElement(actuators, "position", joint=mapped.joint_name(joint), kp=str(kp), kv="2")
    model = doc.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)

    def body(name: str) -> np.ndarray:
        pos: np.ndarray = data.xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)]
        return pos.copy()

    def qpos(joint: str) -> float:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, mapped.joint_name(joint))
        return float(data.qpos[model.jnt_qposadr[jid]])

    gripper_before = body("gripper_base")
    gap_before = np.linalg.norm(body("left_gripper") - body("right_gripper"))
    for i, joint in enumerate(targets):
        assert mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, model.actuator_trnid[i, 0]) == (
            mapped.joint_name(joint)
        )
        data.ctrl[i] = targets[joint]
    for _ in range(int(3.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)

    for joint, target in targets.items():
        assert abs(qpos(joint) - target) < 0.25 * abs(target), (joint, qpos(joint), target)
    assert np.linalg.norm(body("gripper_base") - gripper_before) > 0.05
    gap = np.linalg.norm(body("left_gripper") - body("right_gripper"))
    assert gap - gap_before > 0.75 * 0.03  # each finger opened most of its 0.015 m
    poses = forward_kinematics(robot, {joint: qpos(joint) for joint in targets})
    for link, pose in poses.items():
        np.testing.assert_allclose(body(link), pose.translation, atol=1e-9, err_msg=link)
    tool, gripper = poses["tool_link"], poses["gripper_base"]
    offset = tool.rotation.T @ (gripper.translation - tool.translation)
    np.testing.assert_allclose(offset, [0.01, 0.0, 0.0], atol=1e-12)  # the second definition's
