"""Mesh conventions of real robot packages: COLLADA units/up axis, colours and textures,
ASCII/huge/truncated STL; `urdf check` loads meshes exactly as the simulator does."""

from __future__ import annotations

import warnings
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh
from PIL import Image

from simbridge.errors import UrdfError
from simbridge.sim.sensors import OffscreenRenderer, Pose
from simbridge.sim.urdf import (
    MeshCache,
    MjcfDocument,
    MjcfOptions,
    UrdfWarning,
    add_robot,
    load_urdf,
    urdf_check,
)
from tests.sim.mesh_samples import ascii_stl, binary_stl, collada


def _urdf(tmp_path: Path, mesh: str, material: str = "", collision: bool = True) -> Path:
    geometry = f'<geometry><mesh filename="{mesh}"/></geometry>'
    col = f"<collision>{geometry}</collision>" if collision else ""
    path = tmp_path / "robot.urdf"
    path.write_text(
        f"""<robot name="r">
  <link name="base"><visual>{geometry}{material}</visual>{col}</link>
</robot>"""
    )
    return path


def _build(path: Path, tmp_path: Path, up_axis: bool = False) -> tuple[mujoco.MjModel, list[str]]:
    doc = MjcfDocument()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        add_robot(doc, load_urdf(path), MjcfOptions(), MeshCache(tmp_path / "cache", up_axis))
    messages = [str(w.message) for w in caught if issubclass(w.category, UrdfWarning)]
    return doc.compile(), messages


def _extent(model: mujoco.MjModel, geom: str) -> np.ndarray:
    mesh = model.geom_dataid[model.geom(geom).id]
    start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rot = data.geom_xmat[model.geom(geom).id].reshape(3, 3)
    verts = model.mesh_vert[start : start + count] @ rot.T
    return np.asarray(np.ptp(verts, axis=0))


def test_collada_unit_is_honoured(tmp_path: Path) -> None:
    # 1 unit = 0.00254 m: the cube is 2.54 mm, not 1 m (394x too big before).
    (tmp_path / "housing.dae").write_text(collada(unit=0.00254))
    model, _ = _build(_urdf(tmp_path, "housing.dae"), tmp_path)
    for geom in ("base/visual/0", "base/collision/0"):
        np.testing.assert_allclose(_extent(model, geom), [0.00254] * 3, rtol=1e-6)


def _centre(model: mujoco.MjModel, geom: str) -> np.ndarray:
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return np.asarray(data.geom_xpos[model.geom(geom).id])


def test_collada_up_axis_ignored_like_rviz_unless_asked(tmp_path: Path) -> None:
    # The cube spans [0, 1]^3 in the file. rviz ignores <up_axis> (so files are authored to
    # look right there); honouring Y_UP maps the file's (x, y, z) to (x, -z, y).
    (tmp_path / "cube.dae").write_text(collada(up="Y_UP"))
    path = _urdf(tmp_path, "cube.dae")
    model, _ = _build(path, tmp_path)
    np.testing.assert_allclose(_centre(model, "base/collision/0"), [0.5, 0.5, 0.5], atol=1e-6)
    model, _ = _build(path, tmp_path, up_axis=True)
    np.testing.assert_allclose(_centre(model, "base/collision/0"), [0.5, -0.5, 0.5], atol=1e-6)
    np.testing.assert_allclose(_centre(model, "base/visual/0"), [0.5, -0.5, 0.5], atol=1e-6)


def test_collada_material_colours_reach_the_visual_geoms(tmp_path: Path) -> None:
    red, green = (1.0, 0.0, 0.0, 1.0), (0.0, 0.5, 0.0, 1.0)
    (tmp_path / "two.dae").write_text(collada(colours=(red, green)))
    # the URDF's own grey applies only where the mesh has no colour (as in rviz)
    grey = '<material name="grey"><color rgba="0.5 0.5 0.5 1"/></material>'
    model, _ = _build(_urdf(tmp_path, "two.dae", grey), tmp_path)
    colours = {tuple(np.round(model.geom(n).rgba, 2)) for n in ("base/visual/0", "base/visual/0.1")}
    assert colours == {red, green}  # (to 8-bit precision)
    assert model.ngeom == 3  # two visual parts, one collision geom


def test_stl_takes_the_urdf_material(tmp_path: Path) -> None:
    binary_stl(tmp_path / "cube.stl", trimesh.creation.box())
    blue = '<material name="blue"><color rgba="0 0 1 1"/></material>'
    model, _ = _build(_urdf(tmp_path, "cube.stl", blue), tmp_path)
    assert tuple(model.geom("base/visual/0").rgba) == (0.0, 0.0, 1.0, 1.0)


def test_vertex_colours_split_into_coloured_parts(tmp_path: Path) -> None:
    from tests.sim.mesh_samples import VERTS

    colours = np.where(VERTS[:, 2:3] > 0.5, [[1, 1, 0, 1]], [[0, 0, 1, 1]]).astype(float)
    (tmp_path / "painted.dae").write_text(collada(vertex_colours=colours))
    model, _ = _build(_urdf(tmp_path, "painted.dae", collision=False), tmp_path)
    found = {tuple(np.round(model.geom_rgba[g], 2)) for g in range(model.ngeom)}
    assert (1.0, 1.0, 0.0, 1.0) in found  # top faces
    assert (0.0, 0.0, 1.0, 1.0) in found  # bottom faces


def test_diffuse_texture_is_drawn(tmp_path: Path) -> None:
    Image.new("RGB", (2048, 2048), (20, 200, 40)).save(tmp_path / "skin.png")
    (tmp_path / "skinned.dae").write_text(collada(texture="skin.png"))
    model, _ = _build(_urdf(tmp_path, "skinned.dae", collision=False), tmp_path)
    assert model.ntex == 1
    assert model.nmat == 1
    assert model.tex_width[0] == 1024  # downscaled: MuJoCo keeps textures uncompressed
    geom = model.geom("base/visual/0")
    assert model.geom_matid[geom.id] == 0
    assert model.mat_texid[0][mujoco.mjtTextureRole.mjTEXROLE_RGB] == 0
    # a camera looking down at the cube sees the texture's green; OffscreenRenderer picks
    # the headless GL backend itself (mujoco.Renderer would use GLFW, which needs a display)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    down = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # x forward = -z
    renderer = OffscreenRenderer(model, 32, 32)
    try:
        image = renderer.render_rgb(data, Pose(np.array([0.5, 0.5, 3.0]), down), 0.5, 0.1, 10.0)
    finally:
        renderer.close()
    centre = image[16, 16].astype(int)
    assert centre[1] > 2 * centre[0], centre
    assert centre[1] > 2 * centre[2], centre


def test_ascii_stl_is_converted(tmp_path: Path) -> None:
    ascii_stl(tmp_path / "cube.stl")
    model, messages = _build(_urdf(tmp_path, "cube.stl"), tmp_path)
    np.testing.assert_allclose(_extent(model, "base/collision/0"), [1, 1, 1], atol=1e-9)
    assert messages == []


def test_huge_stl_is_simplified_with_a_warning(tmp_path: Path) -> None:
    sphere = trimesh.creation.icosphere(subdivisions=7, radius=0.1)  # 327,680 faces
    binary_stl(tmp_path / "scan.stl", sphere)
    path = _urdf(tmp_path, "scan.stl", collision=False)
    model, messages = _build(path, tmp_path)
    assert all(n <= 200_000 for n in model.mesh_facenum)
    np.testing.assert_allclose(_extent(model, "base/visual/0"), [0.2] * 3, atol=0.01)
    assert len(messages) == 1
    assert messages[0].startswith(f"{path}: base/")
    assert f"mesh '{tmp_path / 'scan.stl'}' has 327680 faces, over MuJoCo's limit" in messages[0]
    # `urdf check` reports the same problem
    assert "has 327680 faces" in urdf_check(path)


def test_truncated_binary_stl_is_a_clear_error_in_check_and_sim(tmp_path: Path) -> None:
    binary_stl(tmp_path / "cut.stl", trimesh.creation.box(), truncate=30)
    path = _urdf(tmp_path, "cut.stl")
    message = r"mesh '.*cut\.stl': binary STL is truncated or corrupt: its header says 12"
    with pytest.raises(UrdfError, match=message):
        _build(path, tmp_path)
    with pytest.raises(UrdfError, match=message):
        urdf_check(path)


def test_single_triangle_colour_parts_are_dropped(tmp_path: Path) -> None:
    # 12 faces over 7 materials: two parts of one triangle (3 vertices), which MuJoCo
    # cannot take as a mesh; the other five parts are drawn.
    colours = tuple((i / 7, 0.5, 0.5, 1.0) for i in range(7))
    (tmp_path / "many.dae").write_text(collada(colours=colours))
    model, _ = _build(_urdf(tmp_path, "many.dae", collision=False), tmp_path)
    assert model.ngeom == 5


def test_scene_key_honours_collada_up_axis(tmp_path: Path) -> None:
    import yaml

    from simbridge.sim.scene import load_scene
    from simbridge.sim.world import World

    (tmp_path / "cube.dae").write_text(collada(up="Y_UP"))
    _urdf(tmp_path, "cube.dae")
    for key, centre in (("ignore", [0.5, 0.5, 0.5]), ("honour", [0.5, -0.5, 0.5])):
        robot = {"urdf": "robot.urdf", "collada_up_axis": key}
        (tmp_path / "scene.yaml").write_text(yaml.safe_dump({"robots": [robot]}))
        world = World.from_scene(load_scene(tmp_path / "scene.yaml"))
        np.testing.assert_allclose(_centre(world.model, "base/collision/0"), centre, atol=1e-6)
