"""Suite built from scene-file dictionaries: rates in sim time, laziness, wire encoding."""

from __future__ import annotations

import os
from collections import Counter

import mujoco
import numpy as np
import pytest

from simbridge.errors import SimError
from simbridge.messages import default_registry
from simbridge.sim.sensors import (
    Lidar2DConfig,
    Publication,
    SensorSuite,
    build_sensor,
    configure_gl,
)
from simbridge.sim.sensors.gl_backend import is_software_renderer, probe_egl
from tests.sim.sensors.conftest import forward_model

SCENE = """
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <geom name="wall" type="box" pos="2 0 0.5" size="0.05 1 0.5"/>
    <body name="base_link" pos="0 0 0.1">
      <freejoint/>
      <geom type="box" size="0.2 0.15 0.05" mass="5"/>
      <body name="laser" pos="0.1 0 0.1"><geom type="cylinder" size="0.03 0.02"/></body>
    </body>
  </worldbody>
</mujoco>
"""

CONFIGS = [
    {"type": "lidar_2d", "name": "front", "body": "laser", "rate": 10, "samples": 90},
    {"type": "lidar_3d", "name": "velo", "body": "base_link", "xyz": [0, 0, 0.3],
     "channels": 4, "samples": 180, "rate": 5},
    {"type": "camera", "name": "cam", "body": "base_link", "xyz": [0.2, 0, 0.1],
     "width": 64, "height": 48, "rate": 10},
    {"type": "depth_camera", "name": "depth", "body": "base_link", "topic": "rgbd",
     "width": 32, "height": 24, "rate": 10},
    {"type": "imu", "name": "imu", "body": "base_link", "rate": 100},
    {"type": "odometry", "name": "odom", "body": "base_link", "rate": 20},
]  # fmt: skip


@pytest.fixture
def world():
    model, data = forward_model(SCENE)
    suite = SensorSuite.from_config(model, CONFIGS)
    yield model, data, suite
    suite.close()


def run(model, data, suite, seconds: float) -> list[Publication]:
    published = list(suite.poll(model, data))
    for _ in range(round(seconds / model.opt.timestep) - 1):
        mujoco.mj_step(model, data)
        published.extend(suite.poll(model, data))
    return published


def test_each_sensor_publishes_at_its_rate_in_sim_time(world):
    model, data, suite = world
    counts = Counter(pub.topic for pub in run(model, data, suite, 1.0))
    assert counts["scan"] == 10
    assert counts["points"] == 5
    assert counts["camera/image_raw"] == 10
    assert counts["camera/image_raw/compressed"] == 10
    assert counts["rgbd/depth/image"] == 10
    assert counts["imu"] == 100
    assert counts["odom"] == 20
    assert counts["/tf"] == 20


def test_every_message_survives_the_ros1_codec(world):
    model, data, suite = world
    registry = default_registry()
    seen = set()
    for pub in suite.poll(model, data):
        seen.add(pub.topic)
        wire = registry.encode(pub.message, pub.msgtype)
        back = registry.decode(wire, pub.msgtype)
        assert registry.encode(back, pub.msgtype) == wire
    assert seen == set(suite.outputs)


def test_unwanted_topics_cost_nothing_and_rates_survive_sleep(world, monkeypatch):
    model, data, suite = world
    for topic in suite.outputs:
        suite.set_wanted(topic, False)
    calls: list[int] = []
    real = mujoco.mj_multiRay

    def counting(*args):
        calls.append(1)
        real(*args)

    monkeypatch.setattr(mujoco, "mj_multiRay", counting)
    assert run(model, data, suite, 0.5) == []
    assert calls == []
    suite.set_wanted("scan", True)
    counts = Counter(pub.topic for pub in run(model, data, suite, 1.0))
    assert counts == {"scan": 10}
    assert len(calls) == 10


def test_static_frames_for_offset_mounts(world):
    model, _, suite = world
    frames = {s.name: s.static_frame(model) for s in suite.sensors}
    assert frames["front"] is None  # data frame is the `laser` body itself
    assert frames["imu"] is None
    parent, child, pose = frames["velo"]
    assert (parent, child) == ("base_link", "velo")
    np.testing.assert_allclose(pose.position, [0, 0, 0.3])
    assert frames["cam"][:2] == ("base_link", "cam_optical_frame")


def test_config_errors_name_the_problem():
    model = mujoco.MjModel.from_xml_string(SCENE)
    with pytest.raises(SimError, match=r"unknown type 'sonar' \(valid: lidar_2d"):
        build_sensor(model, {"type": "sonar", "name": "s", "body": "laser"})
    with pytest.raises(SimError, match=r"unknown option 'sample'; did you mean 'samples'\?"):
        build_sensor(model, {"type": "lidar_2d", "name": "s", "body": "laser", "sample": 5})
    with pytest.raises(SimError, match=r"missing required option 'body'"):
        build_sensor(model, {"type": "imu", "name": "s"})
    with pytest.raises(SimError, match=r"samples: must be an integer, got 2\.5"):
        Lidar2DConfig.from_config({"name": "s", "body": "laser", "samples": 2.5})
    with pytest.raises(SimError, match="xyz: needs 3 values"):
        Lidar2DConfig.from_config({"name": "s", "body": "laser", "xyz": [1, 2]})
    with pytest.raises(SimError, match="already used"):
        SensorSuite.from_config(
            model,
            [
                {"type": "imu", "name": "a", "body": "laser"},
                {"type": "imu", "name": "b", "body": "laser"},
            ],
        )
    config = Lidar2DConfig.from_config(
        {"type": "lidar_2d", "name": "s", "body": "laser", "rate": 5, "geomgroup": [1] * 6}
    )
    assert config.rate == 5.0
    assert isinstance(config.rate, float)
    assert config.geomgroup == (1, 1, 1, 1, 1, 1)


def test_gl_backend_honours_mujoco_gl(monkeypatch):
    choose = configure_gl.__wrapped__
    # the choice is written into os.environ: let monkeypatch restore both variables, so a
    # GPU machine's later tests are not left with PYOPENGL_PLATFORM=osmesa beside MUJOCO_GL=egl
    monkeypatch.delenv("PYOPENGL_PLATFORM", raising=False)
    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    assert choose() == "osmesa"
    monkeypatch.setenv("MUJOCO_GL", "wgl")
    with pytest.raises(SimError, match="MUJOCO_GL='wgl'"):
        choose()
    monkeypatch.delenv("MUJOCO_GL")
    monkeypatch.setenv("PYOPENGL_PLATFORM", "osmesa")
    assert choose() == "osmesa"
    monkeypatch.setenv("MUJOCO_GL", "egl")  # mujoco.egl would refuse with a garbled message
    with pytest.raises(SimError, match="MUJOCO_GL='egl' but PYOPENGL_PLATFORM='osmesa'"):
        choose()


def test_gl_backend_probes_egl_and_prefers_it_only_on_a_gpu(monkeypatch):
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.delenv("PYOPENGL_PLATFORM", raising=False)
    renderer = probe_egl()
    expected = "osmesa" if renderer is None or is_software_renderer(renderer) else "egl"
    assert configure_gl.__wrapped__() == expected
    assert os.environ["MUJOCO_GL"] == expected
    assert is_software_renderer("llvmpipe (LLVM 15.0.6, 256 bits)")
    assert not is_software_renderer("NVIDIA H100 80GB HBM3/PCIe/SSE2")


def test_the_documented_scene_example_builds():
    import textwrap

    import yaml

    from simbridge.sim import sensors

    doc = sensors.__doc__ or ""
    example = textwrap.dedent(doc[doc.index("    sensors:") : doc.index("Every entry")])
    model = mujoco.MjModel.from_xml_string(
        """<mujoco><worldbody><body name="base_link"><freejoint/><geom size=".1"/>
        <body name="laser_link"/><body name="camera_link"/></body></worldbody></mujoco>"""
    )
    suite = SensorSuite.from_config(model, yaml.safe_load(example)["sensors"])
    try:
        assert [type(s).__name__ for s in suite.sensors] == [
            "Lidar2D", "Lidar3D", "Camera", "DepthCamera", "Imu", "Odometry",
        ]  # fmt: skip
        assert suite.outputs["camera/depth/points"] == "sensor_msgs/PointCloud2"
    finally:
        suite.close()
