"""The live-labels scene: a camera with labelers on the world body looking at a turned
crate, a ball and a pillar (labelled by a `labels:` entry), with the geometry to check the
published boxes against. Shared by the local, ROS 1 and ROS 2 live-label tests."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np

from simbridge.sim.sensors import Camera, PinholeModel, optical_pose
from simbridge.sim.world import World
from tests.sim.urdf_samples import GRAVITY_ARM

__all__ = [
    "CAMERA_TOPIC",
    "CLASSES",
    "CRATE_SIZE",
    "CRATE_XYZ",
    "CRATE_YAW",
    "HEIGHT",
    "WIDTH",
    "crate_pixel_box",
    "labelled_scene",
]

WIDTH, HEIGHT = 96, 72
CAMERA_TOPIC = "/cam"
CLASSES = ("ball", "crate", "post")
"""Class ids 1, 2, 3 (the scene's `perception.classes`)."""
CRATE_XYZ, CRATE_YAW, CRATE_SIZE = (1.6, 0.25, 0.2), 0.5, (0.3, 0.2, 0.25)


def labelled_scene(
    folder: Path, *, rate: float = 10.0, ros: bool = True, multisamples: int = 0, arm: bool = False
) -> Path:
    """The scene file, written to `folder`; its camera publishes every label at `rate` Hz
    (rendering its image with `multisamples`); with `arm`, a labelled arm (class arm)
    stands behind the camera, out of its view."""
    x, y, z = CRATE_XYZ
    sx, sy, sz = CRATE_SIZE
    robots = ""
    if arm:
        (folder / "arm.urdf").write_text(GRAVITY_ARM)
        robots = "robots:\n  - {urdf: arm.urdf, name: arm, label: arm, base: {xyz: [-2, 0, 0]}}\n"
    text = f"""\
ros: {{enabled: {str(ros).lower()}, tf: false}}
{robots}objects:
  - {{name: floor, type: plane, rgba: [0.4, 0.4, 0.4, 1]}}
  - {{name: crate, type: box, size: [{sx}, {sy}, {sz}], label: crate,
     pose: {{xyz: [{x}, {y}, {z}], rpy: [0, 0, {CRATE_YAW}]}}}}
  - {{name: ball, type: sphere, size: [0.12], label: ball, pose: {{xyz: [1.8, -0.4, 0.15]}}}}
  - {{name: pillar, type: cylinder, size: [0.05, 0.6], pose: {{xyz: [2.4, -0.05, 0.3]}}}}
lights:
  - {{type: directional, pos: [0, 0, 3], dir: [0.1, 0.2, -1], cast_shadows: false}}
sensors:
  - {{type: camera, name: cam, body: world, xyz: [0, 0, 0.6], rpy: [0, 0.3, 0],
     topic: {CAMERA_TOPIC}, rate: {rate}, width: {WIDTH}, height: {HEIGHT}, fovy: 1.0,
     multisamples: {multisamples}, labelers: [instance, semantic, boxes_2d]}}
perception:
  classes: [{", ".join(CLASSES)}]
  labels:
    - {{name: pillar, class: post, bodies: [pillar]}}
  cameras:  # the live camera's view: 0.3 rad down from (0, 0, 0.6), the same field of view
    - {{name: main, width: {WIDTH}, height: {HEIGHT}, fovy: {math.degrees(1.0)!r},
       eye: [0, 0, 0.6], target: [{math.cos(0.3)!r}, 0, {0.6 - math.sin(0.3)!r}]}}
"""
    path = folder / "labelled.yaml"
    path.write_text(text)
    return path


def crate_pixel_box(world: World, camera: Camera) -> tuple[float, float, float, float]:
    """(u_min, v_min, u_max, v_max) of the crate's 8 corners projected by `camera`."""
    centre = np.array(CRATE_XYZ)
    c, s = math.cos(CRATE_YAW), math.sin(CRATE_YAW)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    half = np.array(CRATE_SIZE) / 2
    signs = np.array(list(itertools.product((-1, 1), repeat=3)), dtype=float)
    corners = centre + (signs * half) @ rotation.T
    optical = optical_pose(camera.world_pose(world.data))
    points = (corners - optical.position) @ optical.rotation
    pinhole = PinholeModel(WIDTH, HEIGHT, camera.config.fovy)
    uv = pinhole.project(points)
    low, high = uv.min(axis=0), uv.max(axis=0)
    return (float(low[0]), float(low[1]), float(high[0]), float(high[1]))
