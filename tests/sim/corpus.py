"""The example-robot-data corpus (real robot descriptions from PyPI) and a reference forward
kinematics written independently of simbridge's importer (own XML walk, scipy rotations)."""

from __future__ import annotations

import sysconfig
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = ["CORPUS", "MOBILE", "SHARE", "corpus_files", "reference_fk"]

SHARE = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share"
CORPUS = SHARE / "example-robot-data" / "robots"

MOBILE = (
    "a1_description",
    "anymal_b_simple_description",
    "anymal_c_simple_description",
    "b1_description",
    "bolt_description",
    "centauro_description",
    "g1_description",
    "go1_description",
    "go2_description",
    "human_description",
    "hyq_description",
    "icub_description",
    "laikago_description",
    "pr2_description",
    "quadruped_description",
    "romeo_description",
    "simple_humanoid_description",
    "solo_description",
    "talos_data/robots/talos_full",
    "talos_data/robots/talos_reduced",
    "tiago_description",
    "tiago_pro_description",
)
"""Robots that stand or roll on the floor (free base); the rest are fixed at their root:
arms, hands, upper bodies (Alex), pendulums, a lower body on a stand, flying bases."""


def corpus_files() -> list[str]:
    """Every URDF in the corpus, relative to `CORPUS` (empty if the package is missing)."""
    return sorted(str(p.relative_to(CORPUS)) for p in CORPUS.rglob("*.urdf"))


def _joint_motion(joint: ET.Element, value: float) -> tuple[Rotation, np.ndarray]:
    if joint.get("type") not in ("revolute", "continuous", "prismatic"):
        return Rotation.identity(), np.zeros(3)  # fixed joints may carry an axis of 0 0 0
    axis_elem = joint.find("axis")
    axis = np.array(
        [
            float(v)
            for v in (axis_elem.get("xyz", "1 0 0") if axis_elem is not None else "1 0 0").split()
        ]
    )
    axis = axis / np.linalg.norm(axis)
    if joint.get("type") in ("revolute", "continuous"):
        return Rotation.from_rotvec(axis * value), np.zeros(3)
    return Rotation.identity(), axis * value


def reference_fk(path: Path, values: dict[str, float]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """(rotation matrix, position) of every link in the root link's frame, at `values`
    (missing joints at 0; a mimic joint follows its leader when the leader exists; the first
    of duplicate joint definitions counts, as simbridge documents)."""
    root = ET.parse(path).getroot()
    joints: dict[str, ET.Element] = {}
    for joint in root.findall("joint"):
        joints.setdefault(joint.get("name", ""), joint)
    parent_joint: dict[str, ET.Element] = {}
    for joint in joints.values():
        child = joint.find("child")
        assert child is not None
        parent_joint.setdefault(child.get("link", ""), joint)
    poses: dict[str, tuple[Rotation, np.ndarray]] = {}

    def value_of(joint: ET.Element) -> float:
        mimic = joint.find("mimic")
        single = joint.get("type") in ("revolute", "continuous", "prismatic")
        if mimic is not None and single and mimic.get("joint") in joints:
            leader = values.get(mimic.get("joint", ""), 0.0)
            return float(mimic.get("multiplier", "1")) * leader + float(mimic.get("offset", "0"))
        return values.get(joint.get("name", ""), 0.0)

    def pose(link: str) -> tuple[Rotation, np.ndarray]:
        if link in poses:
            return poses[link]
        joint = parent_joint.get(link)
        if joint is None:
            result = (Rotation.identity(), np.zeros(3))
        else:
            parent = joint.find("parent")
            assert parent is not None
            rot, pos = pose(parent.get("link", ""))
            origin = joint.find("origin")
            xyz = np.array(
                [
                    float(v)
                    for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()
                ]
            )
            rpy = [
                float(v)
                for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()
            ]
            o_rot = Rotation.from_euler("xyz", rpy)  # extrinsic X, Y, Z: URDF's fixed axes
            m_rot, m_pos = _joint_motion(joint, value_of(joint))
            rot, pos = rot * o_rot, pos + rot.apply(xyz)
            result = (rot * m_rot, pos + rot.apply(m_pos))
        poses[link] = result
        return result

    links = {link.get("name", "") for link in root.findall("link")}
    return {name: (pose(name)[0].as_matrix(), pose(name)[1]) for name in links}
