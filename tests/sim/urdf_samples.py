"""URDF snippets the simulator tests build robots from."""

from __future__ import annotations


def inertial(mass: float = 1.0, i: float = 0.01, xyz: str = "0 0 0") -> str:
    """An <inertial> block with a diagonal tensor."""
    return (
        f'<inertial><origin xyz="{xyz}"/><mass value="{mass}"/>'
        f'<inertia ixx="{i}" iyy="{i}" izz="{i}" ixy="0" ixz="0" iyz="0"/></inertial>'
    )


def link(name: str, body: str | None = None) -> str:
    """A link with a default inertial unless `body` is given."""
    return f'<link name="{name}">{inertial() if body is None else body}</link>'


def joint(name: str, jtype: str, parent: str, child: str, extra: str = "") -> str:
    """A joint; `extra` holds origin/axis/limit/... elements."""
    return (
        f'<joint name="{name}" type="{jtype}"><parent link="{parent}"/>'
        f'<child link="{child}"/>{extra}</joint>'
    )


def robot(*parts: str, name: str = "r") -> str:
    """Wrap parts in <robot>."""
    return f'<robot name="{name}">{"".join(parts)}</robot>'


PLANAR_ARM = robot(
    link("base"),
    link("l1"),
    link("l2"),
    link("tool", ""),
    joint(
        "j1",
        "revolute",
        "base",
        "l1",
        '<origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>'
        '<limit lower="-3" upper="3" effort="100" velocity="1"/>',
    ),
    joint(
        "j2",
        "revolute",
        "l1",
        "l2",
        '<origin xyz="0.5 0 0"/><axis xyz="0 0 1"/>'
        '<limit lower="-3" upper="3" effort="100" velocity="1"/>',
    ),
    joint("tool_joint", "fixed", "l2", "tool", '<origin xyz="0.3 0 0"/>'),
    name="planar_arm",
)
"""Two links rotating about Z: lengths 0.5 and 0.3, base height 0.1."""

ALL_TYPES = robot(
    link("base"),
    link("rev"),
    link("cont"),
    link("pris"),
    link("fix"),
    link("flo"),
    link("pla"),
    link("mim"),
    joint(
        "j_rev",
        "revolute",
        "base",
        "rev",
        '<origin xyz="0.1 0.2 0.3" rpy="0.1 0.2 0.3"/><axis xyz="1 1 0"/>'
        '<limit lower="-2" upper="2" effort="10" velocity="1"/>'
        '<dynamics damping="0.5" friction="0.1"/>',
    ),
    joint(
        "j_cont",
        "continuous",
        "rev",
        "cont",
        '<origin xyz="0 0 0.2" rpy="0.5 0 0"/><axis xyz="0 1 0"/>',
    ),
    joint(
        "j_pris",
        "prismatic",
        "cont",
        "pris",
        '<origin xyz="0.1 0 0" rpy="0 0 -0.4"/><axis xyz="0 0 1"/>'
        '<limit lower="-0.5" upper="0.5" effort="10" velocity="1"/>',
    ),
    joint("j_fix", "fixed", "pris", "fix", '<origin xyz="0 0.1 0" rpy="0.3 -0.2 0.1"/>'),
    joint("j_flo", "floating", "fix", "flo", '<origin xyz="0.2 0 0"/>'),
    joint(
        "j_pla", "planar", "flo", "pla", '<origin xyz="0 0 0.1" rpy="0 0.3 0"/><axis xyz="0 0 1"/>'
    ),
    joint(
        "j_mim",
        "revolute",
        "pla",
        "mim",
        '<origin xyz="0 0 0.05"/><axis xyz="0 0 1"/>'
        '<limit lower="-5" upper="5" effort="10" velocity="1"/>'
        '<mimic joint="j_rev" multiplier="-2" offset="0.1"/>',
    ),
    name="all_types",
)
"""One joint of every URDF type (and a mimic), with rotated origins and odd axes."""

_Y_LIMIT = '<axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="200" velocity="2"/>'

GRAVITY_ARM = robot(
    link("base", inertial(5.0, 0.05)),
    link(
        "upper",
        inertial(1.0, 0.01, "0.25 0 0")
        + '<collision><origin xyz="0.25 0 0"/><geometry><box size="0.5 0.05 0.05"/></geometry>'
        "</collision>",
    ),
    link(
        "fore",
        inertial(0.8, 0.008, "0.15 0 0")
        + '<collision><origin xyz="0.15 0 0"/><geometry><box size="0.3 0.04 0.04"/></geometry>'
        "</collision>",
    ),
    link("spin", inertial(0.2, 0.001)),
    link("finger_a", inertial(0.05, 1e-5)),
    link("finger_b", inertial(0.05, 1e-5)),
    joint("shoulder", "revolute", "base", "upper", '<origin xyz="0 0 0.5"/>' + _Y_LIMIT),
    joint("elbow", "revolute", "upper", "fore", '<origin xyz="0.5 0 0"/>' + _Y_LIMIT),
    joint("wrist", "continuous", "fore", "spin", '<origin xyz="0.3 0 0"/><axis xyz="1 0 0"/>'),
    joint(
        "grip_a",
        "prismatic",
        "spin",
        "finger_a",
        '<axis xyz="0 1 0"/><limit lower="0" upper="0.05" effort="20" velocity="0.5"/>',
    ),
    joint(
        "grip_b",
        "prismatic",
        "spin",
        "finger_b",
        '<axis xyz="0 1 0"/><limit lower="-0.05" upper="0" effort="20" velocity="0.5"/>'
        '<mimic joint="grip_a" multiplier="-1"/>',
    ),
    name="gravity_arm",
)
"""An arm whose shoulder and elbow lift against gravity (axes along Y), a wrist and a gripper."""
