"""What `simbridge urdf check` and `simbridge urdf fk` print: a tree report and link poses."""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path

from simbridge.errors import UrdfError
from simbridge.sim.urdf.diagnostics import UrdfWarning
from simbridge.sim.urdf.kinematics import JointValue, forward_kinematics
from simbridge.sim.urdf.loader import load_urdf
from simbridge.sim.urdf.mjcf import robot_to_mjcf
from simbridge.sim.urdf.robot import Joint, JointType, Robot

__all__ = [
    "check_report",
    "fk_poses",
    "parse_joint_assignments",
    "parse_xacro_args",
    "urdf_check",
    "urdf_fk",
]


def _joint_line(joint: Joint) -> str:
    text = f"{joint.name} [{joint.type.value}] {joint.parent} -> {joint.child}"
    if joint.type is not JointType.FIXED and joint.type is not JointType.FLOATING:
        text += f" axis ({' '.join(f'{a:g}' for a in joint.axis)})"
    if joint.limit is not None:
        lim = joint.limit
        if joint.limited:
            text += f" limits [{lim.lower:g}, {lim.upper:g}]"
        text += f" effort {lim.effort:g} velocity {lim.velocity:g}"
    if joint.dynamics.damping or joint.dynamics.friction:
        text += f" damping {joint.dynamics.damping:g} friction {joint.dynamics.friction:g}"
    if joint.mimic is not None:
        m = joint.mimic
        text += f" mimics {m.joint} (x{m.multiplier:g} {m.offset:+g})"
    return text


def check_report(robot: Robot) -> str:
    """A check_urdf-style report: root, link tree, joints with limits, warnings."""
    lines = [
        f"robot name is: {robot.name}",
        "---------- Successfully Parsed XML ---------------",
        f"root Link: {robot.root} has {len(robot.child_joints(robot.root))} child(ren)",
    ]

    def tree(link: str, depth: int) -> None:
        for joint in robot.child_joints(link):
            lines.append(f"{'    ' * depth}child({depth}):  {joint.child}")
            tree(joint.child, depth + 1)

    tree(robot.root, 1)
    lines.append(f"joints ({len(robot.joints)}):")
    lines.extend(f"  {_joint_line(j)}" for j in robot.joints.values())
    problems = list(robot.warnings)
    # Build and compile the MuJoCo model as `sim` does, so meshes MuJoCo would refuse
    # (or that get converted or simplified) are reported here too.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UrdfWarning)
        doc, _ = robot_to_mjcf(robot)
        doc.compile()
    for warning in caught:
        text = str(warning.message)
        if issubclass(warning.category, UrdfWarning) and text not in problems:
            problems.append(text)
    lines.append(f"warnings ({len(problems)}):")
    lines.extend(f"  {w}" for w in problems)
    return "\n".join(lines) + "\n"


def urdf_check(
    path: str | Path,
    search_paths: Sequence[str | Path] = (),
    xacro_args: Mapping[str, str] | None = None,
    strict: bool = False,
) -> str:
    """Load `path` (URDF or xacro) and return its check report; raises `UrdfError` if malformed."""
    robot = load_urdf(path, search_paths=search_paths, xacro_args=xacro_args, strict=strict)
    return check_report(robot)


def parse_xacro_args(items: Sequence[str]) -> dict[str, str]:
    """Parse CLI xacro args, `NAME:=VALUE` (as roslaunch and xacro take them) or `NAME=VALUE`."""
    values: dict[str, str] = {}
    for item in items:
        sep = ":=" if ":=" in item else "="
        name, found, value = item.partition(sep)
        if not found or not name.strip():
            raise UrdfError(f"xacro arg '{item}': expected NAME:=VALUE (or --arg NAME=VALUE)")
        values[name.strip()] = value
    return values


def parse_joint_assignments(items: Sequence[str]) -> dict[str, JointValue]:
    """Parse CLI `JOINT=VALUE` items; VALUE is a number or comma-separated numbers."""
    values: dict[str, JointValue] = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or not name:
            raise UrdfError(f"--set '{item}': expected JOINT=VALUE")
        try:
            numbers = [float(v) for v in text.split(",")]
        except ValueError:
            raise UrdfError(f"--set '{item}': '{text}' is not a number") from None
        if any(math.isnan(v) or math.isinf(v) for v in numbers):
            raise UrdfError(f"--set '{item}': value must be finite")
        values[name] = numbers[0] if len(numbers) == 1 else tuple(numbers)
    return values


def fk_poses(
    robot: Robot, values: Mapping[str, JointValue] | None = None
) -> dict[str, dict[str, list[float]]]:
    """`{"link": {"xyz": [...], "quat_xyzw": [...]}}` for every link, in the root link's frame."""
    poses = forward_kinematics(robot, values)
    return {
        link: {"xyz": list(tf.xyz), "quat_xyzw": list(tf.quat_xyzw)} for link, tf in poses.items()
    }


def urdf_fk(
    path: str | Path,
    assignments: Sequence[str] = (),
    search_paths: Sequence[str | Path] = (),
    xacro_args: Mapping[str, str] | None = None,
    strict: bool = False,
) -> dict[str, dict[str, list[float]]]:
    """`simbridge urdf fk FILE --set J=V ...`: every link's pose as a JSON-ready dict."""
    robot = load_urdf(path, search_paths=search_paths, xacro_args=xacro_args, strict=strict)
    return fk_poses(robot, parse_joint_assignments(assignments))
