"""Conventions of real URDF files: tolerated with a warning naming file, line and element;
errors in strict mode. Each sample is a small file of our own reproducing the convention."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from simbridge.errors import UrdfError
from simbridge.sim.urdf import UrdfWarning, load_urdf, robot_to_mjcf

# A joint defined twice with the same parent and child: a true duplicate (a joint name
# reused for another child is another joint: tests/sim/urdf/test_urdf_reused_joint_name.py).
DUPLICATE_JOINT = """<robot name="dup">
  <link name="hand"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial></link>
  <link name="tool"/>
  <joint name="hand_tool_joint" type="fixed">
    <parent link="hand"/><child link="tool"/>
    <origin xyz="0 0 0.1"/>
  </joint>
  <joint name="hand_tool_joint" type="fixed">
    <parent link="hand"/><child link="tool"/>
    <origin xyz="0 0 0.5"/>
  </joint>
</robot>
"""


def _write(tmp_path: Path, text: str, name: str = "robot.urdf") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _load(path: Path, **kwargs: object) -> tuple[object, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = load_urdf(path, **kwargs)  # type: ignore[arg-type]
    return robot, [str(w.message) for w in caught if issubclass(w.category, UrdfWarning)]


def test_duplicate_joint_keeps_first_with_warning_naming_file_and_line(tmp_path: Path) -> None:
    path = _write(tmp_path, DUPLICATE_JOINT)
    robot, messages = _load(path)
    assert len(messages) == 1
    assert messages[0] == (
        f"{path}:9: joint 'hand_tool_joint' is defined twice; keeping the first definition (line 5)"
    )
    joint = robot.joints["hand_tool_joint"]  # type: ignore[attr-defined]
    assert joint.origin.xyz == (0.0, 0.0, 0.1)
    doc, _ = robot_to_mjcf(robot)  # type: ignore[arg-type]
    doc.compile()


def test_duplicate_link_keeps_first(tmp_path: Path) -> None:
    text = """<robot name="r">
  <link name="a"/>
  <link name="a"><visual><geometry><box size="1 1 1"/></geometry></visual></link>
</robot>"""
    robot, messages = _load(_write(tmp_path, text))
    assert messages == [
        f"{tmp_path / 'robot.urdf'}:3: link 'a' is defined twice; "
        "keeping the first definition (line 2)"
    ]
    assert robot.links["a"].visuals == ()  # type: ignore[attr-defined]


def test_strict_mode_refuses_duplicates(tmp_path: Path) -> None:
    path = _write(tmp_path, DUPLICATE_JOINT)
    with pytest.raises(UrdfError, match=rf"^{path}:9: joint 'hand_tool_joint' is defined twice"):
        load_urdf(path, strict=True)


def _chain(*joints: tuple[str, str, str]) -> str:
    """A robot whose joints are (name, parent, child), one per line from line 3."""
    names = sorted({link for _, parent, child in joints for link in (parent, child)})
    lines = [
        f'  <joint name="{name}" type="fixed"><parent link="{parent}"/><child link="{child}"/>'
        "</joint>"
        for name, parent, child in joints
    ]
    return (
        "\n".join(
            ['<robot name="r">', "  " + "".join(f'<link name="{n}"/>' for n in names), *lines]
        )
        + "\n</robot>\n"
    )


def test_reused_joint_name_takes_the_first_free_suffix(tmp_path: Path) -> None:
    path = _write(tmp_path, _chain(("j", "a", "b"), ("j_2", "b", "c"), ("j", "c", "d")))
    robot, messages = _load(path)
    assert messages == [
        f"{path}:5: joint 'j' is defined twice for different links "
        "(line 3: a -> b; this one: c -> d); keeping both, this one as 'j_3'"
    ]
    assert [(j.name, j.child) for j in robot.joints.values()] == [  # type: ignore[attr-defined]
        ("j", "b"),
        ("j_2", "c"),
        ("j_3", "d"),
    ]


def test_repeat_of_a_renamed_joint_is_a_duplicate(tmp_path: Path) -> None:
    path = _write(tmp_path, _chain(("j", "a", "b"), ("j", "b", "c"), ("j", "b", "c")))
    robot, messages = _load(path)
    assert len(messages) == 2  # the rename, then the repeat
    assert messages[1] == (
        f"{path}:5: joint 'j' (kept as 'j_2') is defined twice; "
        "keeping the first definition (line 4)"
    )
    assert sorted(robot.joints) == ["j", "j_2"]  # type: ignore[attr-defined]


def test_same_name_and_child_from_another_parent_keeps_the_first(tmp_path: Path) -> None:
    # A link has one parent: the second joint to `c` cannot be kept beside the first.
    path = _write(tmp_path, _chain(("j", "a", "b"), ("k", "b", "c"), ("k", "a", "c")))
    robot, messages = _load(path)
    assert messages == [
        f"{path}:5: joint 'k' (a -> c; the first: b -> c) is defined twice; "
        "keeping the first definition (line 4)"
    ]
    assert robot.joints["k"].parent == "b"  # type: ignore[attr-defined]


def test_material_defined_in_an_earlier_visual_is_found(tmp_path: Path) -> None:
    # urdfdom (and the Allegro hand's files) let a visual define a named colour that later
    # visuals reference by name.
    text = """<robot name="r">
  <link name="a"><visual><geometry><box size="1 1 1"/></geometry>
    <material name="black"><color rgba="0.1 0.1 0.1 1"/></material></visual></link>
  <link name="b"><visual><geometry><box size="1 1 1"/></geometry>
    <material name="black"/></visual></link>
  <joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint>
</robot>"""
    robot, messages = _load(_write(tmp_path, text))
    assert messages == []
    material = robot.links["b"].visuals[0].material  # type: ignore[attr-defined]
    assert material.rgba == (0.1, 0.1, 0.1, 1.0)


def test_undefined_material_warns_then_errors_in_strict_mode(tmp_path: Path) -> None:
    text = """<robot name="r">
  <link name="a"><visual><geometry><box size="1 1 1"/></geometry>
    <material name="nope"/></visual></link>
</robot>"""
    path = _write(tmp_path, text)
    robot, messages = _load(path)
    assert len(messages) == 1
    assert messages[0].startswith(f"{path}:3: link 'a' <visual> #0: material 'nope' is not")
    assert robot.links["a"].visuals[0].material is None  # type: ignore[attr-defined]
    with pytest.raises(UrdfError, match=r"robot.urdf:3: .*material 'nope'.*strict mode"):
        load_urdf(path, strict=True)


def test_mimic_of_missing_joint_moves_on_its_own(tmp_path: Path) -> None:
    text = """<robot name="r">
  <link name="a"/>
  <link name="b"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1"/></inertial></link>
  <joint name="finger" type="revolute"><parent link="a"/><child link="b"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
    <mimic joint="index_q1" multiplier="2"/>
  </joint>
</robot>"""
    path = _write(tmp_path, text)
    robot, messages = _load(path)
    assert messages == [
        f"{path}:6: joint 'finger' <mimic>: joint 'index_q1' is not defined; "
        "the joint moves on its own"
    ]
    assert robot.joints["finger"].mimic is None  # type: ignore[attr-defined]
    with pytest.raises(UrdfError, match="strict mode"):
        load_urdf(path, strict=True)


def test_limit_without_range_is_simulated_unlimited(tmp_path: Path) -> None:
    # centauro's wheels: type="revolute" with <limit effort velocity/> ("actually continuous").
    text = """<robot name="r">
  <link name="a"/>
  <link name="b"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1"/></inertial></link>
  <joint name="wheel" type="revolute"><parent link="a"/><child link="b"/>
    <limit effort="35" velocity="20"/>
  </joint>
</robot>"""
    path = _write(tmp_path, text)
    robot, messages = _load(path)
    assert messages == [
        f"{path}:5: joint 'wheel' <limit>: no lower/upper (range [0, 0]); "
        "simulating the joint without position limits"
    ]
    assert not robot.joints["wheel"].limited  # type: ignore[attr-defined]
    doc, _ = robot_to_mjcf(robot)  # type: ignore[arg-type]
    assert doc.compile().jnt_limited[0] == 0


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            """<robot name="r">
  <link name="a"/>
  <link name="b"/>
  <joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>
  <joint name="j2" type="fixed"><parent link="b"/><child link="a"/></joint>
</robot>""",
            r"robot.urdf:1: the joints form a cycle through link\(s\) a -> b",
        ),
        (
            """<robot name="r">
  <link name="root"/>
  <link name="a"/>
  <link name="b"/>
  <joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>
  <joint name="j2" type="fixed"><parent link="b"/><child link="a"/></joint>
</robot>""",
            r"robot.urdf:1: the joints form a cycle through link\(s\) a -> b "
            r"\(unreachable from root 'root'",
        ),
        (
            """<robot name="r">
  <link name="a"/>
  <joint name="j" type="fixed"><parent link="a"/><child link="ghost"/></joint>
</robot>""",
            r"robot.urdf:3: joint 'j': child link 'ghost' is not defined",
        ),
        (
            """<robot name="r">
  <link name="a">
    <inertial><mass value="heavy"/></inertial>
  </link>
</robot>""",
            r"robot.urdf:2: link 'a' <inertial>: attribute value='heavy' is not a number",
        ),
        ("<robot name='r'>\n<link name='a'>", r"robot.urdf: not well-formed XML: .*line 2"),
    ],
)
def test_structural_errors_name_file_line_and_element(
    tmp_path: Path, text: str, message: str
) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(UrdfError, match=message) as info:
        load_urdf(path)
    assert str(info.value).count(str(path)) == 1  # the file is named once


def test_robot_without_name_is_named_after_the_file(tmp_path: Path) -> None:
    # ur3.urdf in example-robot-data has <robot> without a name
    path = _write(tmp_path, "<robot>\n  <link name='a'/>\n</robot>", "ur3.urdf")
    robot, messages = _load(path)
    assert robot.name == "ur3"  # type: ignore[attr-defined]
    assert messages == [f"{path}:1: <robot> is missing attribute 'name'; calling it 'ur3'"]
    with pytest.raises(UrdfError, match="strict mode"):
        load_urdf(path, strict=True)


def test_mimic_on_a_fixed_joint_is_ignored(tmp_path: Path) -> None:
    # Talos' gripper: <joint type="fixed"> with a <mimic>
    text = """<robot name="r">
  <link name="a"/><link name="b"/><link name="c"/>
  <joint name="j" type="continuous"><parent link="a"/><child link="b"/></joint>
  <joint name="f" type="fixed"><parent link="b"/><child link="c"/>
    <mimic joint="j"/></joint>
</robot>"""
    path = _write(tmp_path, text)
    robot, messages = _load(path)
    assert messages == [f"{path}:5: joint 'f': a fixed joint cannot mimic; ignoring <mimic>"]
    assert robot.joints["f"].mimic is None  # type: ignore[attr-defined]


def test_package_uri_with_three_slashes_resolves(tmp_path: Path) -> None:
    # Talos: package:///example-robot-data/robots/talos_data/meshes/...
    from tests.sim.mesh_samples import ascii_stl

    (tmp_path / "pkg" / "meshes").mkdir(parents=True)
    ascii_stl(tmp_path / "pkg" / "meshes" / "m.stl")
    text = """<robot name="r"><link name="a"><visual><geometry>
  <mesh filename="package:///pkg/meshes/m.stl"/></geometry></visual></link></robot>"""
    path = _write(tmp_path, text)
    robot = load_urdf(path, search_paths=[tmp_path], strict=True)
    mesh = robot.links["a"].visuals[0].geometry
    assert mesh.path == (tmp_path / "pkg" / "meshes" / "m.stl").resolve()  # type: ignore[union-attr]


def test_vanishing_inertia_is_replaced(tmp_path: Path) -> None:
    # iCub's ankle: principal moments of 1e-20 kg m^2, which MuJoCo refuses
    from simbridge.sim.urdf import inertial_problem
    from simbridge.sim.urdf.robot import Inertial

    problem = inertial_problem(Inertial(0.746, ixx=2.7e-20, iyy=5.4e-20, izz=1.4e-20))
    assert problem is not None
    assert "not positive definite" in problem
    assert inertial_problem(Inertial(0.01, ixx=1e-9, iyy=1e-9, izz=1e-9)) is None
