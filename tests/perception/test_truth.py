"""Labels against geometry worked out here from the scene's numbers (not golden images):
mask areas, box corners, depth, visibility, ids and poses."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from simbridge.perception import Frame, FrameMaker, InstanceLabel, View
from tests.perception.scenes import (
    BOX_RPY,
    BOX_SIZE,
    BOX_XYZ,
    FOCAL,
    HEIGHT,
    SPHERE_RADIUS,
    SPHERE_XYZ,
    TILE,
    TRUTH_CAMERAS,
    WIDTH,
    look_at_frame,
    pinhole,
)

Array = NDArray[np.float64]
CX, CY = (WIDTH - 1) / 2, (HEIGHT - 1) / 2


def optical_frame(name: str) -> tuple[Array, Array]:
    """World-from-optical rotation (x right, y down, z forward) and position of a camera."""
    return look_at_frame(*TRUTH_CAMERAS[name])


def project(name: str, world: Array) -> Array:
    rotation, eye = optical_frame(name)
    return pinhole(world, rotation, eye, FOCAL, (CX, CY))


def rpy_matrix(roll: float, pitch: float, yaw: float) -> Array:
    """URDF fixed-axis roll, pitch, yaw."""
    cr, sr, cp, sp, cy, sy = (f(a) for a in (roll, pitch, yaw) for f in (math.cos, math.sin))
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return np.asarray(rz @ ry @ rx, dtype=np.float64)


def view(frame: Frame, name: str) -> View:
    return next(v for v in frame.views if v.camera.name == name)


def label(frame: Frame, camera: str, instance: str) -> InstanceLabel:
    return next(i for i in view(frame, camera).labels.instances if i.instance.name == instance)


def test_sphere_mask_area_is_the_projected_disc(truth: tuple[FrameMaker, Frame]) -> None:
    _, frame = truth
    seen = view(frame, "sphere")
    ball = label(frame, "sphere", "ball")
    assert seen.labels.instance_image is not None
    area = int((seen.labels.instance_image == ball.instance.id).sum())
    distance = TRUTH_CAMERAS["sphere"][0][2] - SPHERE_XYZ[2]
    radius = SPHERE_RADIUS
    disc = math.pi * (FOCAL * radius / math.sqrt(distance**2 - radius**2)) ** 2
    assert area == ball.visible_px
    assert abs(area - disc) / disc < 0.02, (area, disc)
    assert abs(ball.amodal_px - disc) / disc < 0.02, (ball.amodal_px, disc)


def test_box_corners_project_inside_the_2d_box_and_touch_it(
    truth: tuple[FrameMaker, Frame],
) -> None:
    _, frame = truth
    crate = label(frame, "box", "crate")
    half = np.array(BOX_SIZE) / 2
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    corners = np.array(BOX_XYZ) + (signs * half) @ rpy_matrix(*BOX_RPY).T
    uv = project("box", corners)
    low, high = uv.min(axis=0), uv.max(axis=0)
    # The amodal box is the projected geometry's: every corner inside, extremes on it.
    u0, v0, u1, v1 = crate.amodal_box
    assert np.allclose([u0, v0, u1, v1], [*low, *high], atol=1e-3)
    # The tight box of the pixels drawn (pixel centres inside the outline) touches the
    # corners' extremes within 1 px and holds every corner within 1 px.
    assert crate.tight_box is not None
    x0, y0, x1, y1 = crate.tight_box
    assert (uv[:, 0] >= x0 - 1).all()
    assert (uv[:, 0] <= x1 + 1).all()
    assert (uv[:, 1] >= y0 - 1).all()
    assert (uv[:, 1] <= y1 + 1).all()
    assert np.abs(np.array([x0, y0, x1, y1]) - np.array([*low, *high])).max() <= 1.0
    assert crate.visibility == 1.0
    assert crate.truncation == 0.0


def test_depth_is_the_distance_to_the_floor(truth: tuple[FrameMaker, Frame]) -> None:
    _, frame = truth
    depth = view(frame, "plane").depth
    assert depth is not None
    assert depth.dtype == np.float32
    rotation, eye = optical_frame("plane")
    u, v = np.meshgrid(np.arange(WIDTH), np.arange(HEIGHT))
    rays = np.stack([(u - CX) / FOCAL, (v - CY) / FOCAL, np.ones_like(u, dtype=float)], -1)
    down = (rays @ rotation.T)[..., 2]  # world z change per metre of optical depth
    with np.errstate(divide="ignore"):
        expected = np.where(down < 0, -eye[2] / down, np.inf)
    near = expected < 5.0  # the floor up to 5 m (MuJoCo draws infinite planes finitely)
    assert near.sum() > WIDTH * HEIGHT // 2
    error = np.abs(depth[near] - expected[near])
    assert error.max() < 1e-3 + 1e-4 * expected[near].max(), error.max()


def test_an_object_half_hidden_has_visibility_one_half(truth: tuple[FrameMaker, Frame]) -> None:
    _, frame = truth
    tile = label(frame, "hidden", "tile")
    assert abs(tile.visibility - 0.5) <= 0.05, (tile.visible_px, tile.amodal_px)
    plate = label(frame, "hidden", "plate")
    assert plate.visibility == 1.0
    # The amodal count is the pixel centres inside the tile's projected outline.
    corners = np.array([[30 - TILE, -TILE, 0.02], [30 + TILE, TILE, 0.02]])
    outline = project("hidden", corners)
    low, high = outline.min(axis=0), outline.max(axis=0)
    columns = np.floor(high[0]) - np.ceil(low[0]) + 1
    rows = np.floor(high[1]) - np.ceil(low[1]) + 1
    assert tile.amodal_px == columns * rows


def test_instance_ids_and_classes_match_the_scene(truth: tuple[FrameMaker, Frame]) -> None:
    maker, frame = truth
    table = maker.table
    assert [(i.id, i.name, i.category) for i in table.instances] == [
        (1, "ball", "ball"),
        (2, "crate", "crate"),
        (3, "tile", "tile"),
        (4, "plate", "plate"),
    ]
    assert list(table.categories) == ["ball", "crate", "tile", "plate"]
    expected = {"sphere": {"ball"}, "box": {"crate"}, "plane": set(), "hidden": {"tile", "plate"}}
    for seen in frame.views:
        names = {i.instance.name for i in seen.labels.instances}
        assert names == expected[seen.camera.name]
        instance, category = seen.labels.instance_image, seen.labels.category_image
        assert instance is not None
        assert category is not None
        ids = set(np.unique(instance).tolist()) - {0}
        assert ids == {table.by_name[n].id for n in names}
        for name in names:
            inst = table.by_name[name]
            assert (category[instance == inst.id] == inst.category_id).all()
        assert (category[instance == 0] == 0).all()
        # Each id's pixels lie about its object's projected centre.
        for seen_label in seen.labels.instances:
            rows, cols = np.nonzero(instance == seen_label.instance.id)
            centre = project(
                seen.camera.name, maker.world.data.xpos[[seen_label.instance.root_body]]
            )
            if seen_label.visibility == 1.0:
                assert np.hypot(cols.mean() - centre[0, 0], rows.mean() - centre[0, 1]) < 3.0


def test_poses_are_the_sims_own_in_the_optical_frame(truth: tuple[FrameMaker, Frame]) -> None:
    maker, frame = truth
    data = maker.world.data
    for seen in frame.views:
        rotation, eye = optical_frame(seen.camera.name)
        assert np.allclose(seen.camera.rotation, rotation)
        assert np.allclose(seen.camera.position, eye)
        for inst_label in seen.labels.instances:
            body = inst_label.instance.root_body
            assert np.allclose(inst_label.rotation, rotation.T @ data.xmat[body].reshape(3, 3))
            assert np.allclose(inst_label.translation, rotation.T @ (data.xpos[body] - eye))
    crate = label(frame, "box", "crate")
    rotation, eye = optical_frame("box")
    assert np.allclose(crate.rotation, rotation.T @ rpy_matrix(*BOX_RPY), atol=1e-9)
    assert np.allclose(crate.translation, rotation.T @ (np.array(BOX_XYZ) - eye), atol=1e-9)
    assert crate.box3d is not None
    assert np.allclose(crate.box3d.size, BOX_SIZE)
    assert np.allclose(crate.box3d.center, crate.translation)
