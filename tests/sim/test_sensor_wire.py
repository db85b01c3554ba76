"""The sensors' precompiled serialization gives the generic path's bytes, in both ROS
generations: ROS 1 binary of the ROS 1 message, and CDR of its ROS 2 translation."""

from __future__ import annotations

import mujoco
import pytest

from simbridge.messages import Translator, default_registry, ros2_registry
from simbridge.sim.ros.sensor_wire import SensorWire
from simbridge.sim.sensors import (
    Imu,
    ImuConfig,
    Lidar2D,
    Lidar2DConfig,
    Odometry,
    OdometryConfig,
    Sensor,
)
from simbridge.sim.sensors.rosmsg import Publication

SCENE = """
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <geom name="wall" type="box" pos="2 0 0.3" size="0.05 1 0.3"/>
    <body name="base_link" pos="0 0 0.3">
      <freejoint/>
      <geom type="box" size="0.2 0.1 0.1" mass="3"/>
    </body>
  </worldbody>
</mujoco>
"""


def _sensors(model: mujoco.MjModel) -> list[Sensor]:
    return [
        Imu(model, ImuConfig(name="imu", body="base_link", gyro_noise=0.01, accel_noise=0.1)),
        Lidar2D(model, Lidar2DConfig(name="laser", body="base_link", samples=45)),
        Lidar2D(
            model,
            Lidar2DConfig(
                name="laser_i", body="base_link", samples=30, intensities=True, topic="scan_i"
            ),
        ),
        Odometry(model, OdometryConfig(name="odom", body="base_link")),
    ]


def _generic(publication: Publication, generation: str) -> bytes:
    ros1 = default_registry()
    if generation == "ROS1":
        return ros1.codec(publication.msgtype).encode(publication.message, "ros1")
    ros2 = ros2_registry()
    message = Translator(ros1, ros2).translate(publication.message)
    return ros2.codec(publication.msgtype).encode(message, "cdr")


@pytest.mark.parametrize("generation", ["ROS1", "ROS2"])
def test_imu_scan_odometry_and_its_tf_match_the_codec(generation: str) -> None:
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    sensors = _sensors(model)
    wire = SensorWire()
    fmt = ("ros1", True) if generation == "ROS1" else ("cdr", False)
    kinds: set[str] = set()
    for _ in range(3):  # the writers' buffers are reused; seq counts up in ROS 1
        for _ in range(25):
            mujoco.mj_step(model, data)
        mujoco.mj_forward(model, data)
        for sensor in sensors:
            for publication in sensor.measure(model, data):
                got = wire.encode(publication, fmt)  # type: ignore[arg-type]
                assert got is not None, publication.msgtype
                assert got == _generic(publication, generation), publication.topic
                kinds.add(publication.msgtype)
    assert kinds == {
        "sensor_msgs/Imu",
        "sensor_msgs/LaserScan",
        "nav_msgs/Odometry",
        "tf2_msgs/TFMessage",
    }


def test_other_kinds_are_left_to_the_codec() -> None:
    message = default_registry().new("std_msgs/String", data="x")
    assert (
        SensorWire().encode(Publication("/s", "std_msgs/String", message), ("ros1", True)) is None
    )
