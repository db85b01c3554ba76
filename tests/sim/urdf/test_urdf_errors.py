"""Malformed URDF documents raise UrdfError naming the element and the problem."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from simbridge.errors import UrdfError
from simbridge.sim.urdf import JointType, load_urdf, parse_urdf
from tests.sim.urdf_samples import ALL_TYPES, joint, link, robot

LIMIT = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'


@pytest.mark.parametrize(
    ("urdf", "message"),
    [
        ("<robot name='r'><link name='a'>", "not well-formed XML"),
        ("<model name='r'/>", r"root element is <model>, expected <robot>"),
        ("<robot><link name='a'/></robot>", "<robot> is missing attribute 'name'"),
        (robot(), "robot 'r' has no <link>"),
        (robot(link("a"), link("a")), "link 'a' is defined twice"),
        (
            robot(link("a"), link("b"), joint("j", "fixed", "missing", "b")),
            "joint 'j': parent link 'missing' is not defined",
        ),
        (
            robot(link("a"), link("b"), joint("j", "fixed", "a", "ghost")),
            "joint 'j': child link 'ghost' is not defined",
        ),
        (
            robot(link("a"), link("b"), joint("j", "hinge", "a", "b")),
            "joint 'j': unknown joint type 'hinge' .valid: revolute, continuous",
        ),
        (robot(link("a"), link("b")), "more than one root link: a, b"),
        (
            robot(
                link("a"), link("b"), joint("j1", "fixed", "a", "b"), joint("j2", "fixed", "b", "a")
            ),
            "cycle",
        ),
        (
            robot(
                link("a"),
                link("b"),
                link("c"),
                joint("j1", "fixed", "a", "c"),
                joint("j2", "fixed", "b", "c"),
            ),
            "joint 'j2': link 'c' already has parent joint 'j1'",
        ),
        (
            robot(link("a"), link("b"), joint("j", "revolute", "a", "b")),
            "joint 'j': a revolute joint needs a <limit> element",
        ),
        (
            robot(
                link("a"),
                link("b"),
                joint(
                    "j",
                    "revolute",
                    "a",
                    "b",
                    '<limit lower="1" upper="-1" effort="1" velocity="1"/>',
                ),
            ),
            r"joint 'j' <limit>: lower=1.0 is above upper=-1.0",
        ),
        (
            robot(link("a"), link("b"), joint("j", "fixed", "a", "b", '<origin xyz="1 2"/>')),
            r"joint 'j' <origin>: attribute xyz='1 2' needs 3 number",
        ),
        (
            robot(link("a"), link("b"), joint("j", "fixed", "a", "b", '<origin xyz="1 two 3"/>')),
            "attribute xyz='1 two 3' is not a number",
        ),
        (
            robot(link("a"), link("b"), joint("j", "continuous", "a", "b", '<axis xyz="0 0 0"/>')),
            "joint 'j': <axis xyz='0 0 0'> is zero",
        ),
        (
            robot(link("a"), link("b"), joint("j", "continuous", "a", "b", '<mimic joint="k"/>')),
            "joint 'j' <mimic>: joint 'k' is not defined",
        ),
        (
            robot(link("a", "<visual><geometry><blob/></geometry></visual>")),
            r"link 'a' <visual> #0: unknown geometry <blob>",
        ),
        (
            robot(link("a", '<collision><geometry><sphere radius="-1"/></geometry></collision>')),
            "radius must be positive",
        ),
        (
            robot(
                link(
                    "a",
                    '<visual><geometry><box size="1 1 1"/></geometry><material name="nope"/>'
                    "</visual>",
                )
            ),
            "material 'nope' is not defined",
        ),
        (
            robot(link("a", '<inertial><mass value="heavy"/></inertial>')),
            r"link 'a' <inertial>: attribute value='heavy' is not a number",
        ),
        (
            robot(
                link("a"),
                link("b"),
                joint("j", "prismatic", "a", "b", LIMIT + '<dynamics damping="-1"/>'),
            ),
            "damping and friction must not be negative",
        ),
    ],
)
def test_malformed_urdf_names_the_problem(urdf: str, message: str) -> None:
    with pytest.raises(UrdfError, match=message):
        parse_urdf(urdf, strict=True)


def test_every_joint_type_parses() -> None:
    robot_ = parse_urdf(ALL_TYPES)
    types = {j.name: j.type for j in robot_.joints.values()}
    assert types == {
        "j_rev": JointType.REVOLUTE,
        "j_cont": JointType.CONTINUOUS,
        "j_pris": JointType.PRISMATIC,
        "j_fix": JointType.FIXED,
        "j_flo": JointType.FLOATING,
        "j_pla": JointType.PLANAR,
        "j_mim": JointType.REVOLUTE,
    }
    rev = robot_.joints["j_rev"]
    assert rev.axis == pytest.approx((2**-0.5, 2**-0.5, 0.0))
    assert rev.limit is not None
    assert (rev.limit.lower, rev.limit.upper, rev.limit.effort) == (-2.0, 2.0, 10.0)
    assert (rev.dynamics.damping, rev.dynamics.friction) == (0.5, 0.1)
    mimic = robot_.joints["j_mim"].mimic
    assert mimic is not None
    assert (mimic.joint, mimic.multiplier, mimic.offset) == ("j_rev", -2.0, 0.1)
    assert robot_.root == "base"
    assert [j.name for j in robot_.movable_joints] == ["j_rev", "j_cont", "j_pris", "j_mim"]


def test_missing_file_and_missing_mesh(tmp_path: Path) -> None:
    with pytest.raises(UrdfError, match="does not exist"):
        load_urdf(tmp_path / "none.urdf")
    path = tmp_path / "r.urdf"
    path.write_text(
        robot(
            link(
                "a",
                '<visual><geometry><mesh filename="package://nopkg/m.stl"/></geometry></visual>',
            )
        )
    )
    loaded = load_urdf(path)  # a missing mesh is a warning for check/fk ...
    assert any("package 'nopkg'" in w for w in loaded.warnings)
    from simbridge.sim.urdf import robot_to_mjcf

    robot_to_mjcf(loaded)[0].compile()  # ... a missing visual is left out of the model ...
    path.write_text(
        robot(
            link(
                "a",
                '<collision><geometry><mesh filename="package://nopkg/m.stl"/></geometry>'
                "</collision>",
            )
        )
    )
    searched = re.escape(f"searched {tmp_path} and every folder above it")
    how = re.escape("add the folder that holds it with --search-path DIR, `search_paths: [DIR]`")
    with pytest.raises(
        UrdfError, match=rf"mesh 'package://nopkg/m\.stl' was not found: .*{searched}.*{how}"
    ):
        robot_to_mjcf(load_urdf(path))  # ... a missing collision mesh is an error
    with pytest.raises(UrdfError, match=r"package 'nopkg'.*strict mode"):
        load_urdf(path, strict=True)
