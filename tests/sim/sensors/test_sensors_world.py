"""Sensors inside a World built from a scene: URDF links as mounts, step hook, reset."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from simbridge.sim.scene import parse_scene
from simbridge.sim.sensors import Publication, attach_sensors
from simbridge.sim.world import World

ROBOT = """<?xml version="1.0"?>
<robot name="scout">
  <link name="base_link">
    <inertial><mass value="5"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>
    </inertial>
    <visual><geometry><box size="2 2 0.2"/></geometry></visual>
    <collision><geometry><box size="0.4 0.3 0.2"/></geometry></collision>
  </link>
  <link name="laser_link">
    <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/>
    </inertial>
    <collision><geometry><cylinder radius="0.04" length="0.05"/></geometry></collision>
  </link>
  <joint name="laser_mount" type="fixed">
    <parent link="base_link"/><child link="laser_link"/>
    <origin xyz="0.1 0 0.3" rpy="0 0 0"/>
  </joint>
</robot>
"""


@pytest.fixture
def world(tmp_path: Path) -> World:
    (tmp_path / "scout.urdf").write_text(ROBOT)
    scene = parse_scene(
        {
            "physics": {"timestep": 0.002, "realtime_factor": 0},
            "robots": [{"urdf": "scout.urdf", "base": {"xyz": [0, 0, 0.1]}}],
            "objects": [{"name": "wall", "type": "box", "size": [0.1, 4, 2],
                         "pose": {"xyz": [3.05, 0, 1]}}],
            "ros": {"enabled": False},
        },
        tmp_path,
    )  # fmt: skip
    return World.from_scene(scene)


def test_lidar_on_a_urdf_link_sees_the_wall_through_the_robots_visuals(world):
    published: list[Publication] = []
    suite = attach_sensors(
        world,
        [{"type": "lidar_2d", "name": "front", "body": "laser_link", "samples": 181,
          "angle_min": -math.pi / 2, "angle_max": math.pi / 2}],
        published.append,
    )  # fmt: skip
    try:
        world.step(499)  # sim time (0, 1): the ticks at t = 0, 0.1, ..., 0.9
    finally:
        suite.close()
    assert len(published) == 10
    scan = published[-1].message
    assert scan.header.frame_id == "laser_link"
    angles = scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges))
    laser_x = world.link_pose("laser_link").translation[0]
    expected = (3.0 - laser_x) / np.cos(angles)
    hits = np.abs(expected * np.sin(angles)) < 1.9
    np.testing.assert_allclose(scan.ranges[hits], expected[hits], atol=1e-3)
    assert np.all(np.isposinf(scan.ranges[np.abs(expected * np.sin(angles)) > 2.1]))


def test_reset_restarts_rates_and_stamps(world):
    published: list[Publication] = []
    suite = attach_sensors(
        world, [{"type": "imu", "name": "imu", "body": "base_link", "rate": 50}], published.append
    )
    try:
        world.step(249)  # (0, 0.5): ticks 0, 0.02, ..., 0.48
        assert len(published) == 25
        world.reset()
        published.clear()
        world.step(249)
    finally:
        suite.close()
    assert len(published) == 25
    first = published[0].message.header.stamp
    assert (first.sec, first.nanosec) == (0, 2_000_000)
    np.testing.assert_allclose([published[-1].message.linear_acceleration.z], [9.81], atol=1e-6)
