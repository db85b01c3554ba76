"""Lidar geometry against a wall at a known distance (analytic d / cos(theta))."""

from __future__ import annotations

import math
import threading

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.errors import SimError
from simbridge.sim.sensors import Lidar2D, Lidar2DConfig, Lidar3D, Lidar3DConfig
from simbridge.sim.sensors.lidar3d import POINT_DTYPE
from tests.sim.sensors.conftest import forward_model

WALL_X = 2.0  # the wall's near face
WALL_HALF_WIDTH = 1.0  # in y
WALL_HALF_HEIGHT = 0.5  # in z, centred at the sensor height z = 1

SCENE = f"""
<mujoco>
  <worldbody>
    <geom name="wall" type="box" pos="{WALL_X + 0.05} 0 1"
          size="0.05 {WALL_HALF_WIDTH} {WALL_HALF_HEIGHT}"/>
    <geom name="decal" type="box" pos="1.0 0 1" size="0.01 3 3" group="2"
          contype="0" conaffinity="0"/>
    <body name="robot" pos="0 0 1">
      <geom name="chassis" type="sphere" size="0.2"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture(scope="module")
def world() -> tuple[mujoco.MjModel, mujoco.MjData]:
    return forward_model(SCENE)


def expected_ranges(angles: np.ndarray, origin_x: float = 0.0) -> np.ndarray:
    """Distance along each planar beam to the wall face, +inf past its edges."""
    with np.errstate(divide="ignore"):
        distance = (WALL_X - origin_x) / np.cos(angles)
    hit_y = distance * np.sin(angles)
    hits = (np.cos(angles) > 0) & (np.abs(hit_y) <= WALL_HALF_WIDTH)
    return np.where(hits, distance, np.inf)


def test_every_beam_matches_the_analytic_wall_distance(world):
    model, data = world
    lidar = Lidar2D(model, Lidar2DConfig(name="scan", body="robot", range_max=30.0))
    result = lidar.scan(model, data)
    expected = expected_ranges(lidar.angles)
    # Beams grazing the wall's edges are ambiguous; stay 1 mm clear of them.
    edge = math.atan2(WALL_HALF_WIDTH, WALL_X)
    clear = np.abs(np.abs(lidar.angles) - edge) > 1e-3
    assert np.isfinite(expected[clear]).sum() > 20
    hits = np.isfinite(expected) & clear
    np.testing.assert_allclose(result.ranges[hits], expected[hits], atol=1e-3, rtol=0)
    assert np.all(np.isposinf(result.ranges[~np.isfinite(expected) & clear]))


def test_offset_and_yawed_mount(world):
    model, data = world
    yaw = 0.3
    config = Lidar2DConfig(name="scan", body="robot", xyz=(0.5, 0.0, 0.0), rpy=(0.0, 0.0, yaw))
    lidar = Lidar2D(model, config)
    result = lidar.scan(model, data)
    expected = expected_ranges(lidar.angles + yaw, origin_x=0.5)
    world_angles = lidar.angles + yaw
    edge_hit_y = (WALL_X - 0.5) * np.tan(world_angles)
    clear = np.abs(np.abs(edge_hit_y) - WALL_HALF_WIDTH) > 5e-3
    hits = np.isfinite(expected) & clear
    assert hits.sum() > 20
    np.testing.assert_allclose(result.ranges[hits], expected[hits], atol=1e-3, rtol=0)
    assert np.all(np.isposinf(result.ranges[~np.isfinite(expected) & clear]))


def test_range_limits_follow_rep_117(world):
    model, data = world
    config = Lidar2DConfig(name="scan", body="robot", range_min=2.1, range_max=2.5)
    result = Lidar2D(model, config).scan(model, data)
    lidar = Lidar2D(model, config)
    expected = expected_ranges(lidar.angles)
    too_close = expected < 2.1 - 1e-3
    in_range = (expected > 2.1 + 1e-3) & (expected < 2.5 - 1e-3)
    too_far = expected > 2.5 + 1e-3
    assert too_close.any()
    assert in_range.any()
    assert too_far.any()
    assert np.all(np.isneginf(result.ranges[too_close]))
    np.testing.assert_allclose(result.ranges[in_range], expected[in_range], atol=1e-3)
    assert np.all(np.isposinf(result.ranges[too_far]))


def test_intensity_is_cosine_of_incidence(world):
    model, data = world
    config = Lidar2DConfig(name="scan", body="robot", intensities=True)
    lidar = Lidar2D(model, config)
    result = lidar.scan(model, data)
    hits = np.isfinite(result.ranges)
    np.testing.assert_allclose(result.intensities[hits], np.cos(lidar.angles[hits]), atol=1e-5)
    assert np.all(result.intensities[~hits] == 0)


def test_noise_is_seeded_and_has_the_configured_spread(world):
    model, data = world
    config = Lidar2DConfig(name="scan", body="robot", noise_stddev=0.01, seed=7, samples=3600)
    first = Lidar2D(model, config).scan(model, data).ranges
    again = Lidar2D(model, config).scan(model, data).ranges
    np.testing.assert_array_equal(first, again)
    other = Lidar2D(model, Lidar2DConfig(**{**config.__dict__, "seed": 8})).scan(model, data)
    assert not np.array_equal(first, other.ranges)
    clean = Lidar2D(model, Lidar2DConfig(name="scan", body="robot", samples=3600))
    truth = clean.scan(model, data).ranges
    both = np.isfinite(first) & np.isfinite(truth)
    error = (first[both] - truth[both]).astype(np.float64)
    assert both.sum() > 500
    assert abs(error.mean()) < 0.002
    assert 0.008 < error.std() < 0.012


def test_laser_scan_message_fields(world):
    model, data = world
    lidar = Lidar2D(model, Lidar2DConfig(name="scan", body="robot", samples=360, rate=10.0))
    (publication,) = lidar.measure(model, data)
    msg = publication.message
    assert publication.topic == "scan"
    assert publication.msgtype == "sensor_msgs/LaserScan"
    assert msg.header.frame_id == "robot"
    assert len(msg.ranges) == 360
    assert msg.ranges.dtype == np.float32
    assert msg.angle_min == pytest.approx(-math.pi)
    assert msg.angle_increment == pytest.approx(2 * math.pi / 360)
    count = round((msg.angle_max - msg.angle_min) / msg.angle_increment) + 1
    assert count == len(msg.ranges)
    assert msg.scan_time == pytest.approx(0.1)
    assert len(msg.intensities) == 0


def test_bad_config_is_rejected(world):
    model, _ = world
    with pytest.raises(SimError, match="range_min"):
        Lidar2D(model, Lidar2DConfig(name="scan", body="robot", range_min=5.0, range_max=1.0))
    with pytest.raises(SimError, match="nowhere"):
        Lidar2D(model, Lidar2DConfig(name="scan", body="nowhere"))


def test_3d_lidar_points_lie_on_the_wall(world):
    model, data = world
    config = Lidar3DConfig(name="velo", body="robot", channels=16, samples=1800)
    lidar = Lidar3D(model, config)
    scan = lidar.scan(model, data)
    elevation = np.linspace(config.vertical_min, config.vertical_max, 16)
    azimuth = np.linspace(config.angle_min, config.angle_max, 1800)
    elev, azim = np.meshgrid(elevation, azimuth, indexing="ij")
    distance = WALL_X / (np.cos(elev) * np.cos(azim))
    y = distance * np.cos(elev) * np.sin(azim)
    z = distance * np.sin(elev)
    inside = (np.cos(azim) > 0) & (np.abs(y) < WALL_HALF_WIDTH) & (np.abs(z) < WALL_HALF_HEIGHT)
    assert len(scan.points) == inside.sum() > 1000
    np.testing.assert_allclose(scan.points[:, 0], WALL_X, atol=1e-3)
    ranges = np.linalg.norm(scan.points.astype(np.float64), axis=1)
    np.testing.assert_allclose(scan.points[:, 2] / ranges, np.sin(elevation[scan.ring]), atol=1e-5)
    np.testing.assert_allclose(np.sort(ranges), np.sort(distance[inside]), atol=1e-3)


def test_point_cloud2_layout(world):
    model, data = world
    lidar = Lidar3D(model, Lidar3DConfig(name="velo", body="robot", channels=4, samples=90))
    (publication,) = lidar.measure(model, data)
    msg = publication.message
    assert publication.msgtype == "sensor_msgs/PointCloud2"
    assert [f.name for f in msg.fields] == ["x", "y", "z", "intensity", "ring"]
    assert [f.datatype for f in msg.fields] == [7, 7, 7, 7, 4]
    assert msg.point_step == 18
    assert msg.height == 1
    assert len(msg.data) == msg.row_step == 18 * msg.width
    records = np.frombuffer(msg.data.tobytes(), dtype=POINT_DTYPE)
    scan = lidar.scan(model, data)
    np.testing.assert_array_equal(records["ring"], scan.ring)
    np.testing.assert_array_equal(records["x"], scan.points[:, 0])
    assert msg.is_dense


def test_threaded_casting_gives_identical_points(world):
    model, data = world
    config = Lidar3DConfig(name="velo", body="robot", channels=16, samples=1800)
    serial = Lidar3D(model, config).scan(model, data)
    threaded_lidar = Lidar3D(model, Lidar3DConfig(**{**config.__dict__, "threads": 3}))
    try:
        threaded = threaded_lidar.scan(model, data)
        assert [t for t in threading.enumerate() if t.name.startswith("raycast")]
    finally:
        threaded_lidar.close()
    np.testing.assert_array_equal(threaded.points, serial.points)
    np.testing.assert_array_equal(threaded.ring, serial.ring)
    assert not [t for t in threading.enumerate() if t.name.startswith("raycast")]


@settings(max_examples=25, deadline=None)
@given(
    distance=st.floats(0.5, 10.0),
    yaw=st.floats(-math.pi, math.pi),
    height=st.floats(-0.3, 0.3),
)
def test_any_wall_distance_and_mount_yaw(distance, yaw, height):
    """A wall spanning y in [-1, 1] at x = distance, seen by a lidar yawed by `yaw`."""
    model = mujoco.MjModel.from_xml_string(
        f"""<mujoco><worldbody>
        <geom type="box" pos="{distance + 0.05} 0 1" size="0.05 1 1"/>
        <body name="robot" pos="0 0 1"><geom type="sphere" size="0.1"/></body>
        </worldbody></mujoco>"""
    )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    config = Lidar2DConfig(
        name="scan", body="robot", xyz=(0.0, 0.0, height), rpy=(0.0, 0.0, yaw), range_max=50.0
    )
    lidar = Lidar2D(model, config)
    ranges = lidar.scan(model, data).ranges
    world_angles = lidar.angles + yaw
    cos = np.cos(world_angles)
    with np.errstate(divide="ignore"):
        expected = distance / cos
    lateral = expected * np.sin(world_angles)
    hits = (cos > 0) & (np.abs(lateral) < 1 - 1e-3)
    misses = (cos <= 0) | (np.abs(lateral) > 1 + 1e-3)
    np.testing.assert_allclose(ranges[hits], expected[hits], atol=1e-3, rtol=0)
    assert np.all(np.isposinf(ranges[misses]))


def test_ignored_robot_bodies_are_seen_through():
    model = mujoco.MjModel.from_xml_string(
        f"""<mujoco><worldbody>
        <geom name="wall" type="box" pos="{WALL_X + 0.05} 0 1" size="0.05 5 1"/>
        <body name="robot" pos="0 0 1">
          <geom type="sphere" size="0.1"/>
          <body name="mast" pos="0.5 0 0"><geom type="box" size="0.05 0.3 0.5"/></body>
          <body name="arm" pos="0.8 0 0"><geom type="box" size="0.05 0.3 0.5"/></body>
        </body>
        </worldbody></mujoco>"""
    )
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    base = {"name": "scan", "body": "robot", "samples": 91,
            "angle_min": -0.4, "angle_max": 0.4}  # fmt: skip
    blocked = Lidar2D(model, Lidar2DConfig.from_config(base)).scan(model, data).ranges
    clear_config = Lidar2DConfig.from_config({**base, "ignore_bodies": ["mast", "arm"]})
    lidar = Lidar2D(model, clear_config)
    clear = lidar.scan(model, data).ranges
    through_mast = np.abs(0.45 * np.tan(lidar.angles)) < 0.29
    np.testing.assert_allclose(blocked[through_mast], 0.45 / np.cos(lidar.angles[through_mast]),
                               atol=1e-3)  # fmt: skip
    np.testing.assert_allclose(clear, WALL_X / np.cos(lidar.angles), atol=1e-3)
    with pytest.raises(SimError, match="'plinth' is not in the model"):
        Lidar2D(model, Lidar2DConfig.from_config({**base, "ignore_bodies": ["plinth"]}))
    threaded = Lidar3D(
        model, Lidar3DConfig(name="v", body="robot", ignore_bodies=("mast", "arm"), samples=360)
    )
    points = threaded.scan(model, data).points
    threaded.close()
    np.testing.assert_allclose(points[:, 0], WALL_X, atol=1e-3)
