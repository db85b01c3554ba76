"""The sensors' precompiled serialization gives the generic path's bytes, in both ROS
generations: ROS 1 binary of the ROS 1 message, and CDR of its ROS 2 translation; and
the sensor publisher, which skips the steps where no sensor is due, keeps every tick."""

from __future__ import annotations

import mujoco
import pytest

from simbridge.assets import robot_urdf
from simbridge.connector import Connector
from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.messages import Translator, default_registry, ros2_registry
from simbridge.sim.ros.sensor_encoder import SensorEncoder
from simbridge.sim.ros.sensor_publisher import SensorPublisher
from simbridge.sim.scene import parse_scene
from simbridge.sim.sensors import (
    Imu,
    ImuConfig,
    Lidar2D,
    Lidar2DConfig,
    Odometry,
    OdometryConfig,
    Sensor,
    SensorSuite,
)
from simbridge.sim.sensors.rosmsg import Publication
from simbridge.sim.world import World

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
    encoder = SensorEncoder()
    fmt = ("ros1", True) if generation == "ROS1" else ("cdr", False)
    kinds: set[str] = set()
    for _ in range(3):  # the writers' buffers are reused; seq counts up in ROS 1
        for _ in range(25):
            mujoco.mj_step(model, data)
        mujoco.mj_forward(model, data)
        for sensor in sensors:
            for publication in sensor.measure(model, data):
                got = encoder.encode(publication, fmt)  # type: ignore[arg-type]
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
        SensorEncoder().encode(Publication("/s", "std_msgs/String", message), ("ros1", True))
        is None
    )


def test_sensor_publisher_keeps_exact_rates_while_skipping_idle_steps() -> None:
    """The publisher polls its sensors only on the steps one is due, yet publishes on
    exactly the steps a suite polled after every step does, also after a world reset."""
    scene = parse_scene(
        {
            "physics": {"timestep": 0.002},
            "robots": [{"urdf": str(robot_urdf("niryo_one"))}],
            "sensors": [
                {"type": "imu", "name": "imu", "body": "base_link", "topic": "/imu", "rate": 50},
                {"type": "lidar_2d", "name": "laser", "body": "base_link", "topic": "/scan",
                 "rate": 15, "samples": 20},
            ],
        },
        robot_urdf("niryo_one").parent,
    )  # fmt: skip
    world, reference = World.from_scene(scene), World.from_scene(scene)
    expected: list[tuple[str, float]] = []
    suite = SensorSuite.from_config(reference.model, scene.sensors)
    reference.add_step_callback(
        lambda w: expected.extend((p.topic, w.time) for p in suite.poll(w.model, w.data, w.refresh))
    )
    reference.add_reset_callback(lambda w: suite.reset())
    got: list[tuple[str, float]] = []
    with EndpointThread(EndpointOptions(port=0)) as endpoint:
        connector = Connector("127.0.0.1", endpoint.port).connect(wait=5)
        try:
            sensors = SensorPublisher(
                world, connector, SensorSuite.from_config(world.model, scene.sensors)
            )
            sensors.always_on = True
            sensors.start()
            connector.publish = lambda topic, msg: got.append((topic, world.time))  # type: ignore[method-assign]
            for w in (world, reference):
                w.step(500)  # 1 s
                w.reset()
                w.step(250)
            sensors.close()
        finally:
            connector.close()
    assert sum(topic == "/imu" for topic, _ in got) > 50 + 25
    assert got == expected
