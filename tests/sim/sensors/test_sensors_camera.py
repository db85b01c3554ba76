"""Camera geometry: a known point projects through the published CameraInfo onto the pixel
where it is rendered; depth there equals the true distance."""

from __future__ import annotations

import io
import math
from typing import Any

import mujoco
import numpy as np
import pytest
from PIL import Image

from simbridge.sim.sensors import (
    Camera,
    CameraConfig,
    DepthCamera,
    DepthCameraConfig,
    optical_pose,
)
from simbridge.sim.sensors.depth_camera import CLOUD_DTYPE
from tests.sim.sensors.conftest import forward_model

BALL = np.array([2.0, 0.35, 1.25])
BALL_RADIUS = 0.03
MOUNT_RPY = (0.05, 0.08, 0.1)

SCENE = f"""
<mujoco>
  <visual><headlight active="0" ambient="0 0 0" diffuse="0 0 0" specular="0 0 0"/></visual>
  <asset><material name="glow" emission="1" rgba="1 1 1 1"/></asset>
  <worldbody>
    <geom name="ball" type="sphere" pos="{BALL[0]} {BALL[1]} {BALL[2]}" size="{BALL_RADIUS}"
          material="glow"/>
    <body name="head" pos="0 0 1">
      <geom type="box" size="0.02 0.02 0.02" rgba="0 0 0 1"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def world() -> tuple[mujoco.MjModel, mujoco.MjData]:
    return forward_model(SCENE)


@pytest.fixture(scope="module")
def camera(world):
    model, _ = world
    config = CameraConfig(
        name="cam",
        body="head",
        xyz=(0.05, 0.0, 0.1),
        rpy=MOUNT_RPY,
        width=320,
        height=240,
        fovy=math.radians(50.0),
    )
    cam = Camera(model, config)
    yield cam
    cam.close()


def ball_in_optical(sensor, data) -> np.ndarray:
    optical = optical_pose(sensor.world_pose(data))
    return optical.rotation.T @ (BALL - optical.position)


def published(sensor, model, data) -> dict[str, Any]:
    return {pub.topic: pub.message for pub in sensor.measure(model, data)}


def test_ball_projects_onto_its_rendered_centroid(world, camera):
    model, data = world
    messages = published(camera, model, data)
    info = messages["camera/camera_info"]
    image = messages["camera/image_raw"]
    pixels = np.asarray(image.data).reshape(image.height, image.width, 3)
    rows, cols = np.nonzero(pixels.sum(axis=2) > 380)
    assert len(rows) > 20
    k = np.asarray(info.K).reshape(3, 3)
    projected = k @ ball_in_optical(camera, data)
    u, v = projected[:2] / projected[2]
    assert abs(cols.mean() - u) < 1.0
    assert abs(rows.mean() - v) < 1.0
    # The ball is off-centre, so a wrong axis convention could not pass.
    assert abs(u - (image.width - 1) / 2) > 20
    assert abs(v - (image.height - 1) / 2) > 20


def test_camera_info_matches_field_of_view(world, camera):
    model, data = world
    info = published(camera, model, data)["camera/camera_info"]
    k = np.asarray(info.K).reshape(3, 3)
    assert 2 * math.atan((info.height / 2) / k[1, 1]) == pytest.approx(math.radians(50.0))
    assert k[0, 0] == pytest.approx(k[1, 1])
    assert (k[0, 2], k[1, 2]) == (159.5, 119.5)
    np.testing.assert_allclose(np.asarray(info.P).reshape(3, 4)[:, :3], k)
    np.testing.assert_array_equal(np.asarray(info.P).reshape(3, 4)[:, 3], 0)
    assert info.distortion_model == "plumb_bob"
    np.testing.assert_array_equal(info.D, np.zeros(5))
    assert info.header.frame_id == "cam_optical_frame"


def test_image_and_compressed_outputs(world, camera):
    model, data = world
    messages = published(camera, model, data)
    image = messages["camera/image_raw"]
    assert image.encoding == "rgb8"
    assert image.step == 3 * image.width
    raw = np.asarray(image.data).reshape(image.height, image.width, 3)
    jpeg = messages["camera/image_raw/compressed"]
    assert jpeg.format == "rgb8; jpeg compressed bgr8"
    decoded = np.asarray(Image.open(io.BytesIO(jpeg.data.tobytes())).convert("RGB"))
    assert decoded.shape == raw.shape
    assert np.abs(decoded.astype(int) - raw.astype(int)).mean() < 3.0
    png_camera = Camera(model, CameraConfig(**{**camera.config.__dict__, "compression": "png"}))
    try:
        png = published(png_camera, model, data)["camera/image_raw/compressed"]
    finally:
        png_camera.close()
    lossless = np.asarray(Image.open(io.BytesIO(png.data.tobytes())).convert("RGB"))
    np.testing.assert_array_equal(lossless, raw)


def test_optical_frame_is_published_as_a_static_transform(world, camera):
    model, _ = world
    parent, child, pose = camera.static_frame(model)
    assert (parent, child) == ("head", "cam_optical_frame")
    np.testing.assert_allclose(pose.position, [0.05, 0.0, 0.1])
    # Optical z is the mount's forward axis (body x).
    forward = pose.rotation[:, 2]
    expected = camera.frame.offset.rotation[:, 0]
    np.testing.assert_allclose(forward, expected, atol=1e-12)


def sphere_depth_at(pixel: tuple[int, int], centre: np.ndarray, k: np.ndarray) -> float:
    """z of the first intersection of the pixel's ray with the ball (optical frame)."""
    col, row = pixel
    ray = np.array([(col - k[0, 2]) / k[0, 0], (row - k[1, 2]) / k[1, 1], 1.0])
    a = ray @ ray
    b = -2 * ray @ centre
    c = centre @ centre - BALL_RADIUS**2
    return float((-b - math.sqrt(b * b - 4 * a * c)) / (2 * a))


@pytest.fixture(scope="module")
def depth_camera(world):
    model, _ = world
    config = DepthCameraConfig(
        name="depth", body="head", rpy=MOUNT_RPY, width=320, height=240, range_max=5.0
    )
    cam = DepthCamera(model, config)
    yield cam
    cam.close()


def test_depth_at_the_ball_is_the_true_distance(world, depth_camera):
    model, data = world
    messages = published(depth_camera, model, data)
    info = messages["camera/depth/camera_info"]
    k = np.asarray(info.K).reshape(3, 3)
    image = messages["camera/depth/image"]
    assert image.encoding == "32FC1"
    depth = np.frombuffer(image.data.tobytes(), dtype="<f4").reshape(image.height, image.width)
    centre = ball_in_optical(depth_camera, data)
    u, v = (k @ centre)[:2] / centre[2]
    pixel = (round(u), round(v))
    true_depth = sphere_depth_at(pixel, centre, k)
    assert abs(depth[pixel[1], pixel[0]] - true_depth) < 1e-3
    hit = np.isfinite(depth)
    assert 20 < hit.sum() < 400
    assert np.all(np.isposinf(depth[~hit]))
    millimetres = np.frombuffer(messages["camera/depth/image_raw"].data.tobytes(), dtype="<u2")
    millimetres = millimetres.reshape(depth.shape)
    np.testing.assert_array_equal(millimetres[hit], np.rint(depth[hit] * 1000))
    np.testing.assert_array_equal(millimetres[~hit], 0)


def test_depth_point_cloud_lies_on_the_ball(world, depth_camera):
    model, data = world
    cloud = published(depth_camera, model, data)["camera/depth/points"]
    assert (cloud.height, cloud.width) == (240, 320)
    assert not cloud.is_dense
    points = np.frombuffer(cloud.data.tobytes(), dtype=CLOUD_DTYPE)
    xyz = np.stack([points["x"], points["y"], points["z"]], axis=1).astype(np.float64)
    valid = np.isfinite(xyz).all(axis=1)
    assert valid.sum() > 20
    centre = ball_in_optical(depth_camera, data)
    radii = np.linalg.norm(xyz[valid] - centre, axis=1)
    np.testing.assert_allclose(radii, BALL_RADIUS, atol=1.5e-3)


def test_closer_than_range_min_reads_negative_infinity(world):
    model, data = world
    config = DepthCameraConfig(
        name="near", body="head", rpy=MOUNT_RPY, width=160, height=120, range_min=2.5
    )
    cam = DepthCamera(model, config)
    try:
        depth = cam.depth(model, data)
    finally:
        cam.close()
    assert np.isneginf(depth).sum() > 5
    assert not np.isfinite(depth).any()


def test_unwanted_camera_never_renders(world, monkeypatch):
    model, data = world

    def refuse(*args, **kwargs):
        raise AssertionError("rendered although nobody wants an image")

    monkeypatch.setattr("simbridge.sim.sensors.camera.OffscreenRenderer", refuse)
    monkeypatch.setattr("simbridge.sim.sensors.depth_camera.OffscreenRenderer", refuse)
    cam = Camera(model, CameraConfig(name="lazy", body="head"))
    depth = DepthCamera(model, DepthCameraConfig(name="lazy_depth", body="head", topic="d"))
    cam.set_all_wanted(False)
    depth.set_all_wanted(False)
    assert not cam.active
    assert cam.poll(model, data) == []
    assert depth.poll(model, data) == []
    cam.set_wanted("camera/camera_info", True)
    depth.set_wanted("d/depth/camera_info", True)
    assert [p.topic for p in cam.measure(model, data)] == ["camera/camera_info"]
    assert [p.topic for p in depth.measure(model, data)] == ["d/depth/camera_info"]
