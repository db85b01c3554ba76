"""Mesh files (STL, OBJ, DAE generated here), package:// resolution, xacro, and inertia repair."""

from __future__ import annotations

import warnings
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh

from simbridge.errors import UrdfError
from simbridge.sim.urdf import (
    COLLISION_GROUP,
    VISUAL_GROUP,
    MeshCache,
    MjcfDocument,
    MjcfOptions,
    UrdfWarning,
    add_robot,
    load_urdf,
    parse_urdf,
)
from tests.sim.urdf_samples import inertial, joint, link, robot

LIMIT = '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'


def _box_mesh(path: Path) -> None:
    """A 0.1 x 0.2 x 0.3 box centred at (0.2, 0, 0) in the file's frame."""
    mesh = trimesh.creation.box(extents=(0.1, 0.2, 0.3))
    mesh.apply_translation((0.2, 0.0, 0.0))
    path.parent.mkdir(parents=True, exist_ok=True)
    mesh.export(str(path))


def _compile(
    urdf: str, tmp_path: Path, base_dir: Path | None = None
) -> tuple[mujoco.MjModel, list[str]]:
    file = (base_dir or tmp_path) / "robot.urdf"
    file.write_text(urdf)
    doc = MjcfDocument()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        add_robot(
            doc,
            load_urdf(file, search_paths=[tmp_path]),
            MjcfOptions(),
            MeshCache(tmp_path / "cache"),
        )
    return doc.compile(), [str(w.message) for w in caught if issubclass(w.category, UrdfWarning)]


def _on_a_joint(tmp_path: Path, body: str, name: str = "arm") -> tuple[mujoco.MjModel, list[str]]:
    """Link `name` of `body` (its XML) on revolute joint "j" from a link "base", compiled."""
    urdf = robot(link("base"), link(name, body), joint("j", "revolute", "base", name, LIMIT))
    return _compile(urdf, tmp_path)


def _forward(model: mujoco.MjModel) -> mujoco.MjData:
    """The model's data at its initial positions, positions and frames computed."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return data


@pytest.mark.parametrize("suffix", ["stl", "obj", "dae"])
def test_meshes_load_in_place_as_visual_and_collision(tmp_path: Path, suffix: str) -> None:
    _box_mesh(tmp_path / "pkg" / "meshes" / f"box.{suffix}")
    (tmp_path / "pkg" / "package.xml").write_text("<package><name>pkg</name></package>")
    geom = f'<geometry><mesh filename="package://pkg/meshes/box.{suffix}"/></geometry>'
    model, _ = _on_a_joint(
        tmp_path,
        inertial() + f'<visual><origin xyz="0 0 0.5"/>{geom}</visual>'
        f'<collision><origin xyz="0 0 0.5"/>{geom}</collision>',
    )
    data = _forward(model)
    vis = model.geom("arm/visual/0")
    col = model.geom("arm/collision/0")
    assert (vis.contype[0], vis.conaffinity[0], vis.group[0]) == (0, 0, VISUAL_GROUP)
    assert col.group[0] == COLLISION_GROUP
    assert col.contype[0] != 0
    # the box's centre stays where the file put it, shifted by the origin
    np.testing.assert_allclose(data.geom_xpos[col.id], [0.2, 0.0, 0.5], atol=1e-6)
    np.testing.assert_allclose(data.geom_xpos[vis.id], [0.2, 0.0, 0.5], atol=1e-6)
    mesh_id = model.geom_dataid[col.id]
    verts = model.mesh_vert[
        model.mesh_vertadr[mesh_id] : model.mesh_vertadr[mesh_id] + model.mesh_vertnum[mesh_id]
    ]
    np.testing.assert_allclose(
        np.ptp(verts, axis=0), [0.1, 0.2, 0.3], atol=1e-6
    )  # axis-aligned box


def test_relative_and_file_uri_meshes_with_scale(tmp_path: Path) -> None:
    _box_mesh(tmp_path / "m" / "box.stl")
    urdf = robot(
        link(
            "a", '<visual><geometry><mesh filename="m/box.stl" scale="2 2 2"/></geometry></visual>'
        ),
        link(
            "b",
            f'<visual><geometry><mesh filename="file://{tmp_path}/m/box.stl"/></geometry></visual>',
        ),
        joint("j", "fixed", "a", "b"),
    )
    model, _ = _compile(urdf, tmp_path)
    data = _forward(model)
    np.testing.assert_allclose(data.geom_xpos[model.geom("a/visual/0").id], [0.4, 0, 0], atol=1e-6)
    np.testing.assert_allclose(data.geom_xpos[model.geom("b/visual/0").id], [0.2, 0, 0], atol=1e-6)


def test_ros_package_path_finds_packages(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _box_mesh(tmp_path / "ws" / "src" / "my_robot" / "box.stl")
    (tmp_path / "ws" / "src" / "my_robot" / "package.xml").write_text("<package/>")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ws"))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "r.urdf").write_text(
        robot(
            link(
                "a",
                '<visual><geometry><mesh filename="package://my_robot/box.stl"/></geometry></visual>',
            )
        )
    )
    loaded = load_urdf(elsewhere / "r.urdf")
    mesh = loaded.links["a"].visuals[0].geometry
    assert (
        getattr(mesh, "path", None) == (tmp_path / "ws" / "src" / "my_robot" / "box.stl").resolve()
    )


def test_xacro_with_args_and_find(tmp_path: Path) -> None:
    _box_mesh(tmp_path / "desc" / "box.stl")
    (tmp_path / "desc" / "package.xml").write_text("<package/>")
    (tmp_path / "desc" / "robot.urdf.xacro").write_text(
        '<robot name="x" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:arg name="len" default="0.1"/>'
        '<xacro:property name="l" value="$(arg len)"/>'
        '<xacro:macro name="seg" params="n"><link name="l${n}">'
        '<visual><geometry><mesh filename="file://$(find desc)/box.stl"/></geometry></visual>'
        "</link></xacro:macro>"
        '<xacro:seg n="0"/><xacro:seg n="1"/>'
        '<joint name="j" type="prismatic"><parent link="l0"/><child link="l1"/>'
        '<origin xyz="${l * 2} 0 0"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>'
        "</robot>"
    )
    loaded = load_urdf(
        tmp_path / "desc" / "robot.urdf.xacro", search_paths=[tmp_path], xacro_args={"len": "0.25"}
    )
    assert list(loaded.links) == ["l0", "l1"]
    assert loaded.joints["j"].origin.xyz == (0.5, 0.0, 0.0)
    assert not loaded.warnings


def test_bad_xacro_is_a_urdf_error(tmp_path: Path) -> None:
    path = tmp_path / "bad.xacro"
    path.write_text(
        '<robot name="x" xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:nope/></robot>'
    )
    with pytest.raises(UrdfError, match=r"bad.xacro: xacro: .*nope"):
        load_urdf(path)


def test_missing_inertial_is_computed_from_collision_box(tmp_path: Path) -> None:
    model, warns = _on_a_joint(
        tmp_path,
        '<collision><origin xyz="0 0 0.5"/><geometry><box size="0.1 0.2 0.3"/></geometry>'
        "</collision>",
    )
    body = model.body("arm")
    mass = 1000 * 0.1 * 0.2 * 0.3
    assert body.mass[0] == pytest.approx(mass)
    expected = mass / 12 * np.array([0.2**2 + 0.3**2, 0.1**2 + 0.3**2, 0.1**2 + 0.2**2])
    np.testing.assert_allclose(sorted(body.inertia), sorted(expected), rtol=1e-9)
    np.testing.assert_allclose(body.ipos, [0, 0, 0.5], atol=1e-12)
    assert len(warns) == 1
    assert "link 'arm'" in warns[0]
    assert "has no <inertial> but moves" in warns[0]


def test_two_collision_shapes_combine_with_parallel_axis(tmp_path: Path) -> None:
    sphere = (
        '<collision><origin xyz="0 0 {z}"/><geometry><sphere radius="0.1"/></geometry></collision>'
    )
    model, _ = _on_a_joint(tmp_path, sphere.format(z=0.5) + sphere.format(z=-0.5))
    m1 = 1000 * 4 / 3 * np.pi * 0.1**3
    i_own = 0.4 * m1 * 0.01
    body = model.body("arm")
    assert body.mass[0] == pytest.approx(2 * m1)
    # about z: just the spheres' own; about x and y: plus m d^2 for d = 0.5
    np.testing.assert_allclose(
        sorted(body.inertia), sorted([2 * i_own + 2 * m1 * 0.25] * 2 + [2 * i_own])
    )


@pytest.mark.parametrize(
    ("inertia_xml", "reason"),
    [
        (inertial(mass=0.0), "mass 0.0"),
        (inertial(mass=float("nan")), "NaN"),
        (
            '<inertial><mass value="1"/>'
            '<inertia ixx="1" iyy="1" izz="-1" ixy="0" ixz="0" iyz="0"/></inertial>',
            "not positive definite",
        ),
        (
            '<inertial><mass value="1"/>'
            '<inertia ixx="1" iyy="1" izz="1" ixy="2" ixz="0" iyz="0"/></inertial>',
            "not positive definite",
        ),
    ],
)
def test_invalid_inertials_are_replaced_with_a_warning(
    tmp_path: Path, inertia_xml: str, reason: str
) -> None:
    model, warns = _on_a_joint(
        tmp_path,
        inertia_xml
        + '<collision><geometry><cylinder radius="0.1" length="0.2"/></geometry></collision>',
    )
    mass = 1000 * np.pi * 0.01 * 0.2
    assert model.body("arm").mass[0] == pytest.approx(mass)
    assert model.body("arm").inertia[2] == pytest.approx(mass * 0.01 / 2)
    assert len(warns) == 1
    assert "link 'arm'" in warns[0]
    assert reason in warns[0]


def test_moving_link_without_any_volume_gets_a_small_mass(tmp_path: Path) -> None:
    urdf = robot(
        link("base"),
        link("arm", ""),
        link("tip", ""),
        joint("j", "revolute", "base", "arm", LIMIT),
        joint("f", "fixed", "arm", "tip"),
    )
    model, warns = _compile(urdf, tmp_path)
    assert model.body("arm").mass[0] == pytest.approx(0.01)
    assert model.body("tip").mass[0] == 0.0  # fixed, no inertial: a massless frame, as URDF allows
    assert warns == [
        f"{tmp_path / 'robot.urdf'}: link 'arm': has no <inertial> but moves and it has no "
        "collision volume; using a 0.01 kg point mass"
    ]


def test_valid_inertial_with_rotated_frame_is_kept(tmp_path: Path) -> None:
    model, warns = _on_a_joint(
        tmp_path,
        '<inertial><origin xyz="0.1 0 0" rpy="0 0 1.5707963267948966"/><mass value="2"/>'
        '<inertia ixx="0.1" iyy="0.2" izz="0.3" ixy="0" ixz="0" iyz="0"/></inertial>',
    )
    assert warns == []
    assert model.body("arm").mass[0] == 2.0
    # the inertia about the body's world-aligned axes: x and y swapped by the 90 degree yaw
    full = np.zeros(9)
    mujoco.mju_quat2Mat(full, model.body("arm").iquat)
    rot = full.reshape(3, 3)
    tensor = rot @ np.diag(model.body("arm").inertia) @ rot.T
    np.testing.assert_allclose(tensor, np.diag([0.2, 0.1, 0.3]), atol=1e-9)


def test_materials_colour_visual_geoms(tmp_path: Path) -> None:
    urdf = robot(
        '<material name="red"><color rgba="1 0 0 1"/></material>',
        link(
            "a",
            '<visual><geometry><box size="1 1 1"/></geometry><material name="red"/></visual>'
            '<visual><geometry><sphere radius="1"/></geometry><material name="x">'
            '<color rgba="0 0 1 0.5"/></material></visual>',
        ),
    )
    model, _ = _compile(urdf, tmp_path)
    np.testing.assert_allclose(model.geom("a/visual/0").rgba, [1, 0, 0, 1])
    np.testing.assert_allclose(model.geom("a/visual/1").rgba, [0, 0, 1, 0.5])
    assert parse_urdf(urdf).materials["red"].rgba == (1.0, 0.0, 0.0, 1.0)


def test_flat_collision_mesh_becomes_a_thin_box(tmp_path: Path) -> None:
    quad = trimesh.Trimesh(
        vertices=np.array([[0, 0, 0], [0.4, 0, 0], [0.4, 0.2, 0], [0, 0.2, 0]], dtype=float),
        faces=[[0, 1, 2], [0, 2, 3]],
    )
    quad.export(str(tmp_path / "quad.stl"))
    geom = '<geometry><mesh filename="quad.stl"/></geometry>'
    model, warns = _on_a_joint(
        tmp_path,
        inertial() + f'<visual>{geom}</visual><collision><origin xyz="0 0 1"/>{geom}</collision>',
        name="pad",
    )
    data = _forward(model)
    box = model.geom("pad/collision/0")
    assert box.type[0] == mujoco.mjtGeom.mjGEOM_BOX
    np.testing.assert_allclose(box.size, [0.2, 0.1, 0.0005])
    np.testing.assert_allclose(data.geom_xpos[box.id], [0.2, 0.1, 1.0], atol=1e-12)
    assert model.geom("pad/visual/0").type[0] == mujoco.mjtGeom.mjGEOM_MESH
    assert warns == [
        f"{tmp_path / 'robot.urdf'}: pad/collision/0: mesh 'quad.stl' is flat; "
        "colliding with a thin box instead"
    ]


def test_open_and_flat_meshes_still_give_inertia(tmp_path: Path) -> None:
    box = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-2])  # one side missing: no volume
    open_box.export(str(tmp_path / "open.stl"))
    trimesh.Trimesh(
        vertices=np.array([[0, 0, 0], [0.4, 0, 0], [0.4, 0.2, 0], [0, 0.2, 0]], dtype=float),
        faces=[[0, 1, 2], [0, 2, 3]],
    ).export(str(tmp_path / "quad.stl"))
    urdf = robot(
        link("base"),
        link("a", '<collision><geometry><mesh filename="open.stl"/></geometry></collision>'),
        link("b", '<collision><geometry><mesh filename="quad.stl"/></geometry></collision>'),
        joint("ja", "revolute", "base", "a", LIMIT),
        joint("jb", "revolute", "base", "b", LIMIT),
    )
    model, warns = _compile(urdf, tmp_path)
    assert model.body("a").mass[0] == pytest.approx(1.0)  # convex hull: the full 10 cm cube
    assert model.body("b").mass[0] == pytest.approx(1000 * 0.4 * 0.2 * 0.001)  # 1 mm plate
    np.testing.assert_allclose(model.body("b").ipos, [0.2, 0.1, 0.0], atol=1e-12)
    assert len(warns) == 3  # two computed inertials, one flat collision mesh
