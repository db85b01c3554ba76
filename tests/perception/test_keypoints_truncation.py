"""Robot keypoints, truncation at the image border and 3D box axes, against geometry
worked out here: a pinhole projection of the sim's own body positions, MuJoCo's ray
casting (not the renderer) for what hides a keypoint, and a tile cut by the image edge."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import mujoco
import numpy as np
import pytest
from numpy.typing import NDArray

from simbridge.perception import Frame, FrameMaker, InstanceLabel, View
from simbridge.perception.annotate import KEYPOINT_DEPTH_TOLERANCE
from tests.perception.scenes import look_at_frame, pinhole

Array = NDArray[np.float64]
URDF = Path(__file__).parents[2] / "src" / "simbridge" / "assets" / "robots" / "niryo_one.urdf"
WIDTH, HEIGHT, FOCAL = 160, 120, 120.0
CENTRE = ((WIDTH - 1) / 2, (HEIGHT - 1) / 2)
CAMERAS = {
    # name: (eye, target, up)
    "side": ((1.0, 0.0, 0.3), (0.0, 0.0, 0.25), (0.0, 0.0, 1.0)),  # a wall hides the wrist
    "close": ((0.45, 0.0, 0.15), (0.0, 0.0, 0.15), (0.0, 0.0, 1.0)),  # the wrist is above it
    "down": (
        (0.0, 3.0, 2.0),
        (0.0, 3.0, 0.0),
        (0.0, 1.0, 0.0),
    ),  # the image's left edge cuts the tile
}
TILE_HALF, TILE_TOP = 0.1, 0.002
DOWN_DEPTH = 2.0 - TILE_TOP
EDGE_X = (-0.5 - CENTRE[0]) * DOWN_DEPTH / FOCAL
"""World x of the down camera's left image edge at the tile's top face."""
TILE_X = EDGE_X + TILE_HALF / 2
"""A quarter of the tile's top face lies left of the image edge."""
DRAWN_GROUPS = np.array([1, 1, 1, 0, 0, 0], dtype=np.uint8)
"""Geom groups the renderer draws (0-2); collision copies sit in group 3."""


def _scene(folder: Path) -> Path:
    cameras = "\n".join(
        f"    - {{name: {name}, width: {WIDTH}, height: {HEIGHT}, fx: {FOCAL}, fy: {FOCAL}, "
        f"eye: {list(eye)}, target: {list(target)}, up: {list(up)}}}"
        for name, (eye, target, up) in CAMERAS.items()
    )
    text = f"""\
ros: {{enabled: false}}
robots:
  - {{name: niryo_one, urdf: {URDF}, label: robot,
     initial_positions: {{joint_2: 0.5, joint_3: -0.8, left_finger_joint: 0.01}}}}
objects:
  - {{name: floor, type: plane}}
  - {{name: wall, type: box, size: [0.02, 0.3, 0.07], pose: {{xyz: [0.6, 0.0, 0.325]}}}}
  - {{name: tile, type: box, size: [{2 * TILE_HALF}, {2 * TILE_HALF}, {TILE_TOP}], label: tile,
     pose: {{xyz: [{TILE_X!r}, 3.0, {TILE_TOP / 2}]}}}}
lights:
  - {{type: directional, pos: [0, 0, 2], dir: [0.2, 0.3, -1], cast_shadows: false}}
perception:
  classes: [robot, tile]
  render: {{near: 0.05, far: 10}}
  cameras:
{cameras}
"""
    path = folder / "keypoints.yaml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[FrameMaker, Frame]]:
    maker = FrameMaker(_scene(tmp_path_factory.mktemp("keypoints")))
    try:
        yield maker, maker.make(0)
    finally:
        maker.close()


def _view(frame: Frame, name: str) -> View:
    return next(v for v in frame.views if v.camera.name == name)


def _label(frame: Frame, camera: str, instance: str) -> InstanceLabel:
    return next(i for i in _view(frame, camera).labels.instances if i.instance.name == instance)


def _neighbours(model: mujoco.MjModel, body: int) -> set[int]:
    """A body, its parent and its children: their surfaces may be drawn over its origin."""
    return {body, int(model.body_parentid[body])} | {
        b for b in range(model.nbody) if int(model.body_parentid[b]) == body and b != body
    }


def _seen_by_ray(maker: FrameMaker, camera: str, pixel: Array, body: int, depth: float) -> bool:
    """Whether a keypoint at optical `depth` is seen through `pixel`, by MuJoCo's ray casting:
    nothing drawn is hit in front of it (beyond the tolerance), or what is hit belongs to its
    body or a neighbour."""
    model, data = maker.world.model, maker.world.data
    rotation, eye = look_at_frame(*CAMERAS[camera])
    ray = rotation @ np.array([(pixel[0] - CENTRE[0]) / FOCAL, (pixel[1] - CENTRE[1]) / FOCAL, 1])
    hit = np.array([-1], dtype=np.int32)
    distance = mujoco.mj_ray(model, data, eye, ray / np.linalg.norm(ray), DRAWN_GROUPS, 1, -1, hit)
    if hit[0] < 0:
        return True
    hit_depth = distance / np.linalg.norm(ray)  # along the optical axis
    if int(model.geom_bodyid[hit[0]]) in _neighbours(model, body):
        return True
    return bool(hit_depth >= depth - KEYPOINT_DEPTH_TOLERANCE)


def test_keypoints_are_the_projected_bodies_with_visibility_flags(
    made: tuple[FrameMaker, Frame],
) -> None:
    """u, v: the sim's body origins through a pinhole worked out here (within 0.5 px, in
    fact to rounding). Flag 0 outside the image, else 2 where MuJoCo's rays say the origin is
    seen and 1 where something else is in front; pixels whose rays at +-0.3 px disagree
    (an edge runs through them) are left out, and every flag must occur."""
    maker, frame = made
    data = maker.world.data
    counts = {0: 0, 1: 0, 2: 0}
    for camera in ("side", "close"):
        robot = _label(frame, camera, "niryo_one")
        assert robot.keypoints is not None
        bodies = list(robot.instance.bodies)
        assert len(robot.keypoints) == len(bodies) >= 10
        rotation, eye = look_at_frame(*CAMERAS[camera])
        uv = pinhole(data.xpos[bodies], rotation, eye, FOCAL, CENTRE)
        depths = (data.xpos[bodies] - eye) @ rotation[:, 2]
        assert (depths > 0.05).all()
        assert np.abs(robot.keypoints[:, :2] - uv).max() < 0.5
        for k, body in enumerate(bodies):
            pixel = np.round(uv[k])
            inside = 0 <= pixel[0] < WIDTH and 0 <= pixel[1] < HEIGHT
            margin = min(
                uv[k, 0] + 0.5, WIDTH - 0.5 - uv[k, 0], uv[k, 1] + 0.5, HEIGHT - 0.5 - uv[k, 1]
            )
            assert abs(margin) > 1.0, f"{camera}: keypoint {k} sits on the image border"
            flag = int(robot.keypoints[k, 2])
            if not inside:
                assert flag == 0, (camera, k)
                counts[0] += 1
                continue
            probes = [pixel + d for d in ((0, 0), (0.3, 0), (-0.3, 0), (0, 0.3), (0, -0.3))]
            seen = {_seen_by_ray(maker, camera, p, body, float(depths[k])) for p in probes}
            if len(seen) == 1:
                assert flag == (2 if seen.pop() else 1), (camera, k, flag)
                counts[flag] += 1
    # The wall hides the wrist from the side camera, the close camera loses it off the top.
    assert counts[0] >= 5
    assert counts[1] >= 5
    assert counts[2] >= 5


def test_truncation_at_the_image_border(made: tuple[FrameMaker, Frame]) -> None:
    """The down camera's left edge cuts a quarter off a thin tile: truncation 0.25, the
    tight box starts at column 0, the amodal box at the tile's projected left edge, and
    what is in the image is all visible."""
    _, frame = made
    tile = _label(frame, "down", "tile")
    assert abs(tile.truncation - 0.25) < 0.01, tile.truncation
    rotation, eye = look_at_frame(*CAMERAS["down"])
    corners = np.array(
        [
            [TILE_X + sx * TILE_HALF, 3.0 + sy * TILE_HALF, TILE_TOP]
            for sx in (-1, 1)
            for sy in (-1, 1)
        ]
    )
    uv = pinhole(corners, rotation, eye, FOCAL, CENTRE)
    assert uv[:, 0].min() < -0.5 < uv[:, 0].max()
    assert tile.amodal_box[0] == pytest.approx(uv[:, 0].min(), abs=0.5)
    assert tile.tight_box is not None
    assert tile.tight_box[0] == 0
    assert abs(tile.tight_box[2] - uv[:, 0].max()) <= 1.0
    assert tile.visibility == 1.0
    # Pixel count: the in-image three quarters of the projected square.
    side = uv[:, 0].max() - uv[:, 0].min()
    assert abs(tile.visible_px - 0.75 * side * side) / (0.75 * side * side) < 0.03


def test_box_3d_axes_in_the_optical_frame(made: tuple[FrameMaker, Frame]) -> None:
    """A one-body instance's 3D box is in its own axes, expressed in the camera's REP 103
    optical frame (x right, y down, z forward); a robot's (several bodies) in world axes.
    Its corners project onto the amodal box."""
    _, frame = made
    tile = _label(frame, "down", "tile")
    rotation, eye = look_at_frame(*CAMERAS["down"])
    assert tile.box3d is not None
    # Looking down with image up along world +y: world +x is image right (optical +x),
    # world +y image up (optical -y), world +z towards the camera (optical -z).
    assert np.allclose(tile.box3d.rotation, np.diag([1.0, -1.0, -1.0]), atol=1e-9)
    assert np.allclose(tile.box3d.rotation, rotation.T @ np.eye(3), atol=1e-9)
    assert np.linalg.det(tile.box3d.rotation) == pytest.approx(1.0)
    assert np.allclose(tile.box3d.size, [2 * TILE_HALF, 2 * TILE_HALF, TILE_TOP])
    assert np.allclose(tile.box3d.center, [TILE_X, 0.0, 2.0 - TILE_TOP / 2], atol=1e-9)
    corners = tile.box3d.corners()
    assert np.allclose(corners @ rotation.T + eye, _world_tile_corners(), atol=1e-9)
    uv = _view(frame, "down").camera.project(corners)
    assert np.allclose(uv.min(axis=0), tile.amodal_box[:2], atol=1e-6)
    assert np.allclose(uv.max(axis=0), tile.amodal_box[2:], atol=1e-6)
    robot = _label(frame, "side", "niryo_one")
    side_rotation, _ = look_at_frame(*CAMERAS["side"])
    assert robot.box3d is not None
    assert np.allclose(robot.box3d.rotation, side_rotation.T, atol=1e-9)


def _world_tile_corners() -> Array:
    """The tile's 8 corners in the world, in Box3D.corners' order (x, then y, then z signs)."""
    return np.array(
        [
            [TILE_X + sx * TILE_HALF, 3.0 + sy * TILE_HALF, TILE_TOP / 2 + sz * TILE_TOP / 2]
            for sx in (-1, 1)
            for sy in (-1, 1)
            for sz in (-1, 1)
        ]
    )
