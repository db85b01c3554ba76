"""Forward kinematics from the URDF, against hand-computed poses and MuJoCo's body poses."""

from __future__ import annotations

import json
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.errors import UrdfError
from simbridge.sim.urdf import (
    Transform,
    fk_poses,
    forward_kinematics,
    parse_joint_assignments,
    parse_urdf,
    robot_to_mjcf,
    urdf_check,
    urdf_fk,
)
from tests.sim.urdf_samples import ALL_TYPES, PLANAR_ARM


def test_planar_arm_matches_hand_computed_poses(tmp_path: Path) -> None:
    path = tmp_path / "arm.urdf"
    path.write_text(PLANAR_ARM)
    poses = urdf_fk(path, ["j1=1.5707963267948966", "j2=-1.5707963267948966"])
    # l1 turned 90 deg at (0, 0, 0.1); j2 sits 0.5 along l1's x = world +y; l2 back to 0 deg.
    assert poses["base"] == {"xyz": [0.0, 0.0, 0.0], "quat_xyzw": [0.0, 0.0, 0.0, 1.0]}
    assert poses["l1"]["xyz"] == pytest.approx([0.0, 0.0, 0.1], abs=1e-9)
    s = math.sqrt(0.5)
    assert poses["l1"]["quat_xyzw"] == pytest.approx([0.0, 0.0, s, s], abs=1e-9)
    assert poses["l2"]["xyz"] == pytest.approx([0.0, 0.5, 0.1], abs=1e-9)
    assert poses["l2"]["quat_xyzw"] == pytest.approx([0.0, 0.0, 0.0, 1.0], abs=1e-9)
    assert poses["tool"]["xyz"] == pytest.approx([0.3, 0.5, 0.1], abs=1e-9)
    json.dumps(poses)  # JSON-ready


def test_rpy_origin_is_fixed_axis_xyz() -> None:
    # rpy = (pi/2, 0, pi/2): roll about X first, then yaw about fixed Z.
    urdf = PLANAR_ARM.replace(
        '<origin xyz="0.3 0 0"/>',
        '<origin xyz="0.3 0 0" rpy="1.5707963267948966 0 1.5707963267948966"/>',
    )
    tool = forward_kinematics(parse_urdf(urdf))["tool"]
    expected = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], dtype=float)  # Rz(90) @ Rx(90)
    np.testing.assert_allclose(tool.rotation, expected, atol=1e-12)
    # quaternion of that matrix: (x, y, z, w) = (0.5, 0.5, 0.5, 0.5)
    assert tool.quat_xyzw == pytest.approx((0.5, 0.5, 0.5, 0.5), abs=1e-12)


def test_prismatic_and_mimic_follow_the_formula() -> None:
    robot = parse_urdf(ALL_TYPES)
    zero = forward_kinematics(robot)
    moved = forward_kinematics(robot, {"j_pris": 0.25, "j_rev": 0.3})
    # prismatic: the child moves 0.25 along its own z axis
    shift = moved["pris"].translation - moved["cont"].apply(np.array([0.1, 0, 0]))
    np.testing.assert_allclose(shift, moved["pris"].rotation @ np.array([0, 0, 0.25]), atol=1e-12)
    # mimic: j_mim = -2 * j_rev + 0.1 about z
    rel = moved["pla"].inverse() @ moved["mim"]
    angle = math.atan2(rel.rotation[1, 0], rel.rotation[0, 0])
    assert angle == pytest.approx(-2 * 0.3 + 0.1, abs=1e-12)
    rel0 = zero["pla"].inverse() @ zero["mim"]
    assert math.atan2(rel0.rotation[1, 0], rel0.rotation[0, 0]) == pytest.approx(0.1, abs=1e-12)


def test_setting_unknown_or_mimic_joint_fails() -> None:
    robot = parse_urdf(ALL_TYPES)
    with pytest.raises(UrdfError, match="unknown joint 'nope'"):
        forward_kinematics(robot, {"nope": 1.0})
    with pytest.raises(UrdfError, match="j_mim' mimics 'j_rev'"):
        forward_kinematics(robot, {"j_mim": 1.0})
    with pytest.raises(UrdfError, match="takes 3 number"):
        forward_kinematics(robot, {"j_pla": 1.0})


def test_parse_joint_assignments() -> None:
    assert parse_joint_assignments(["a=1.5", "b=1,2,3"]) == {"a": 1.5, "b": (1.0, 2.0, 3.0)}
    for bad in ("a", "=1", "a=x", "a=nan"):
        with pytest.raises(UrdfError):
            parse_joint_assignments([bad])


def _mujoco_poses(values: dict[str, object]) -> tuple[dict[str, Transform], dict[str, Transform]]:
    robot = parse_urdf(ALL_TYPES)
    doc, info = robot_to_mjcf(robot)
    model = doc.compile()
    data = mujoco.MjData(model)
    for name, value in values.items():
        mapping = info.joints[name]
        vals = [value] if isinstance(value, float) else list(value)  # type: ignore[call-overload]
        if name == "j_flo":  # slides x y z, then the ball's quaternion (w x y z)
            x, y, z, qx, qy, qz, qw = vals
            vals = [x, y, z]
            adr = model.joint(mapping.mj_joints[3]).qposadr[0]
            data.qpos[adr : adr + 4] = (qw, qx, qy, qz)
        for mj_name, v in zip(mapping.mj_joints, vals, strict=False):
            data.qpos[model.joint(mj_name).qposadr[0]] = v
    lead = values.get("j_rev", 0.0)
    assert isinstance(lead, float)
    data.qpos[model.joint("j_mim").qposadr[0]] = -2 * lead + 0.1
    mujoco.mj_kinematics(model, data)
    mj = {
        link: Transform(
            data.xmat[model.body(link).id].reshape(3, 3), data.xpos[model.body(link).id]
        )
        for link in robot.links
    }
    return forward_kinematics(robot, values), mj  # type: ignore[arg-type]


angles = st.floats(-2.0, 2.0)


@settings(max_examples=40, deadline=None)
@given(
    rev=angles,
    cont=st.floats(-6.0, 6.0),
    pris=st.floats(-0.5, 0.5),
    flo=st.tuples(*[st.floats(-1, 1)] * 3, *[st.floats(-1, 1)] * 4).filter(
        lambda v: np.linalg.norm(v[3:]) > 0.1
    ),
    pla=st.tuples(st.floats(-1, 1), st.floats(-1, 1), angles),
)
def test_fk_equals_mujoco_body_poses_for_every_joint_type(rev, cont, pris, flo, pla) -> None:
    ours, mj = _mujoco_poses(
        {"j_rev": rev, "j_cont": cont, "j_pris": pris, "j_flo": flo, "j_pla": pla}
    )
    for link, tf in ours.items():
        np.testing.assert_allclose(mj[link].translation, tf.translation, atol=1e-6, err_msg=link)
        np.testing.assert_allclose(mj[link].rotation, tf.rotation, atol=1e-6, err_msg=link)


def test_fk_poses_quaternions_are_unit_and_w_positive() -> None:
    poses = fk_poses(parse_urdf(ALL_TYPES), {"j_rev": 1.0, "j_cont": 2.5})
    for pose in poses.values():
        q = np.array(pose["quat_xyzw"])
        assert np.linalg.norm(q) == pytest.approx(1.0)
        assert q[3] >= 0


def test_check_report_lists_tree_joints_and_limits(tmp_path: Path) -> None:
    path = tmp_path / "all.urdf"
    path.write_text(ALL_TYPES)
    report = urdf_check(path)
    assert "robot name is: all_types" in report
    assert "root Link: base has 1 child(ren)" in report
    assert "child(7):  mim" in report
    assert "j_rev [revolute] base -> rev" in report
    assert "limits [-2, 2] effort 10 velocity 1 damping 0.5 friction 0.1" in report
    assert "j_mim [revolute] pla -> mim axis (0 0 1) limits [-5, 5]" in report
    assert "mimics j_rev (x-2 +0.1)" in report
    assert "warnings (0):" in report
