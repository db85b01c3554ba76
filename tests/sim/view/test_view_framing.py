"""The live view's initial camera frames the robots, not the floor and walls: every robot
shape lies inside the camera's field of view, the robot fills a good part of it, and the
camera is near (geometric truth from the shapes' corners, not from the framing code)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from simbridge.apps.mobile_robot import SCENE_PATH as MOBILE_SCENE
from simbridge.apps.pick_and_place.scene import SCENE_PATH as ARM_SCENE
from simbridge.sim.scene import load_scene
from simbridge.sim.view import Shape, visual_shapes
from simbridge.sim.view.framing import MIN_DISTANCE, framed_bodies
from simbridge.sim.world import World

pytest.importorskip("viser")

from simbridge.sim.view import LiveView, ViewOptions


def _corners(world: World, shape: Shape) -> np.ndarray:
    """World points on `shape`: a box's 8 corners, else its centre +- its size per axis."""
    if shape.kind == "box":
        half = np.array(shape.size) / 2
        local = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        local = local * half
    elif shape.kind == "mesh":
        assert shape.vertices is not None
        local = np.asarray(shape.vertices, dtype=float)
    else:
        r = shape.size[0]
        h = shape.size[1] / 2 if shape.kind == "cylinder" else r
        local = np.array([[r, 0, 0], [-r, 0, 0], [0, r, 0], [0, -r, 0], [0, 0, h], [0, 0, -h]])
    w, x, y, z = shape.wxyz
    geom = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    body = np.asarray(world.data.xmat[shape.body]).reshape(3, 3)
    in_body = local @ geom.T + np.array(shape.position)
    return np.asarray(in_body @ body.T + world.data.xpos[shape.body])


def _angles(points: np.ndarray, eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Angle (rad) between the line of sight and each point."""
    axis = (target - eye) / np.linalg.norm(target - eye)
    rays = points - eye
    cos = rays @ axis / np.linalg.norm(rays, axis=1)
    return np.asarray(np.arccos(np.clip(cos, -1.0, 1.0)))


@pytest.mark.parametrize(
    ("scene", "robot", "objects"),
    [(ARM_SCENE, "niryo_one", ["cube"]), (MOBILE_SCENE, "diffbot", [])],
    ids=["arm", "mobile"],
)
def test_the_initial_camera_frames_the_robot(scene: Path, robot: str, objects: list[str]) -> None:
    world = World.from_scene(load_scene(scene))
    view = LiveView(world, ViewOptions(port=0))
    try:
        camera = view.server.initial_camera
        eye, target, fov = np.array(camera.position), np.array(camera.look_at), camera.fov
    finally:
        view.close()
    shapes = visual_shapes(world.model)
    bodies = set(world.robot(robot).bodies.values())
    bodies |= {world.model.body(name).id for name in objects}
    assert bodies <= framed_bodies(world)
    points = np.concatenate([_corners(world, s) for s in shapes if s.body in bodies])
    angles = _angles(points, eye, target)
    # inside the vertical field of view (the page is wider than high)
    assert angles.max() < fov / 2, f"a robot point is {math.degrees(angles.max()):.0f} deg off"
    # the robot fills a good part of the view, not a speck framed with the room or floor
    # (framing every body put the camera 4-9 m away: under fov / 30)
    assert angles.max() > fov / 8
    # the target lies within the robot's (and objects') bounding box
    low, high = points.min(axis=0), points.max(axis=0)
    assert np.all(low - 1e-9 <= target)
    assert np.all(target <= high + 1e-9)
    distance = float(np.linalg.norm(eye - target))
    # the code clamps to MIN_DISTANCE: the norm of the offset may land a last bit below it
    assert distance == pytest.approx(MIN_DISTANCE) or MIN_DISTANCE < distance < 1.5
    assert eye[2] > target[2], "looking down at it"
    # floor, walls and table are not what is framed
    scenery = {"floor", "table", "wall_north", "wall_south", "wall_east", "wall_west"}
    assert not {world.model.body(b).name for b in framed_bodies(world)} & scenery


def test_a_small_robot_keeps_the_minimum_distance() -> None:
    world = World.from_scene(load_scene(MOBILE_SCENE))
    view = LiveView(world, ViewOptions(port=0))
    try:
        camera = view.server.initial_camera
        distance = float(np.linalg.norm(np.array(camera.position) - np.array(camera.look_at)))
    finally:
        view.close()
    assert distance == pytest.approx(MIN_DISTANCE)
