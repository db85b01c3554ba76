"""IMU at rest and in rotation, and odometry of a driven planar base, against hand math."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from simbridge.sim.sensors import Imu, ImuConfig, Odometry, OdometryConfig

G = 9.81

IMU_SCENE = f"""
<mujoco>
  <option gravity="0 0 -{G}" timestep="0.001"/>
  <worldbody>
    <geom name="floor" type="plane" size="5 5 0.1"/>
    <body name="post" pos="0 0 0.5"><geom type="box" size="0.05 0.05 0.05"/></body>
    <body name="crate" pos="1 0 0.2">
      <freejoint/>
      <geom type="box" size="0.2 0.2 0.2" mass="2"/>
    </body>
    <body name="turntable" pos="-1 0 0.5">
      <joint name="spin" type="hinge" axis="0 0 1"/>
      <geom type="cylinder" size="0.3 0.02" mass="1" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.fixture
def imu_world() -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_string(IMU_SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def test_imu_at_rest_reads_gravity_upward(imu_world):
    model, data = imu_world
    reading = Imu(model, ImuConfig(name="imu", body="post")).read(model, data)
    np.testing.assert_allclose(reading.linear_acceleration, [0, 0, G], atol=1e-9)
    np.testing.assert_allclose(reading.angular_velocity, 0, atol=1e-12)
    np.testing.assert_allclose(reading.orientation_wxyz, [1, 0, 0, 0], atol=1e-12)


def test_rolled_imu_sees_gravity_on_its_own_y_axis(imu_world):
    model, data = imu_world
    config = ImuConfig(name="imu", body="post", rpy=(math.pi / 2, 0.0, 0.0))
    reading = Imu(model, config).read(model, data)
    # Rolled +90 deg about x: the sensor's y axis points up.
    np.testing.assert_allclose(reading.linear_acceleration, [0, G, 0], atol=1e-9)
    half = math.sqrt(0.5)
    np.testing.assert_allclose(reading.orientation_wxyz, [half, half, 0, 0], atol=1e-12)


def test_imu_on_a_box_settled_on_the_floor(imu_world):
    model, data = imu_world
    imu = Imu(model, ImuConfig(name="imu", body="crate"))
    for _ in range(500):
        mujoco.mj_step(model, data)
    reading = imu.read(model, data)
    np.testing.assert_allclose(reading.linear_acceleration, [0, 0, G], atol=0.05)
    np.testing.assert_allclose(reading.angular_velocity, 0, atol=1e-3)


def test_imu_on_a_turntable_feels_centripetal_acceleration(imu_world):
    model, data = imu_world
    omega, radius = 3.0, 0.25
    imu = Imu(model, ImuConfig(name="imu", body="turntable", xyz=(radius, 0.0, 0.0)))
    data.qvel[model.joint("spin").dofadr[0]] = omega
    for _ in range(300):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    reading = imu.read(model, data)
    # Sensor x points away from the axis: centripetal acceleration -omega^2 r along x.
    np.testing.assert_allclose(reading.linear_acceleration, [-(omega**2) * radius, 0, G], atol=1e-6)
    np.testing.assert_allclose(reading.angular_velocity, [0, 0, omega], atol=1e-9)


def test_imu_noise_and_bias_are_seeded(imu_world):
    model, data = imu_world
    config = ImuConfig(
        name="imu", body="post", accel_noise=0.02, gyro_noise=0.01, accel_bias_stddev=0.1, seed=3
    )
    first, second = Imu(model, config), Imu(model, config)
    np.testing.assert_array_equal(first.accel_bias, second.accel_bias)
    readings = np.array([first.read(model, data).linear_acceleration for _ in range(1000)])
    again = np.array([second.read(model, data).linear_acceleration for _ in range(1000)])
    np.testing.assert_array_equal(readings, again)
    assert np.linalg.norm(first.accel_bias) > 0
    np.testing.assert_allclose(
        readings.mean(axis=0), np.array([0, 0, G]) + first.accel_bias, atol=0.003
    )
    np.testing.assert_allclose(readings.std(axis=0), 0.02, rtol=0.1)
    (publication,) = first.measure(model, data)
    assert publication.msgtype == "sensor_msgs/Imu"
    assert publication.message.linear_acceleration_covariance[0] == pytest.approx(0.02**2)


BASE_SCENE = """
<mujoco>
  <option gravity="0 0 0" timestep="0.001"/>
  <worldbody>
    <body name="base_link" pos="1 2 0.1">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="y" type="slide" axis="0 1 0"/>
      <joint name="yaw" type="hinge" axis="0 0 1"/>
      <geom type="box" size="0.3 0.2 0.1" mass="10"/>
    </body>
  </worldbody>
</mujoco>
"""


def drive(model, data, speed: float, turn_rate: float, seconds: float) -> None:
    """Unicycle drive: forward speed along the base's heading and a yaw rate."""

    def command() -> None:
        heading = data.qpos[2]
        data.qvel[:] = [speed * math.cos(heading), speed * math.sin(heading), turn_rate]

    for _ in range(round(seconds / model.opt.timestep)):
        command()
        mujoco.mj_step(model, data)
    command()
    mujoco.mj_forward(model, data)


def test_odometry_of_a_driven_base_follows_the_arc():
    model = mujoco.MjModel.from_xml_string(BASE_SCENE)
    data = mujoco.MjData(model)
    start_yaw = 0.5
    data.qpos[2] = start_yaw
    mujoco.mj_forward(model, data)
    odom = Odometry(model, OdometryConfig(name="odom", body="base_link"))
    start = odom.read(model, data)
    np.testing.assert_allclose(start.pose.position, 0, atol=1e-12)
    speed, turn_rate, seconds = 0.5, 0.4, 2.0
    drive(model, data, speed, turn_rate, seconds)
    reading = odom.read(model, data)
    turned = turn_rate * seconds
    radius = speed / turn_rate
    expected = [radius * math.sin(turned), radius * (1 - math.cos(turned)), 0.0]
    np.testing.assert_allclose(reading.pose.position, expected, atol=2e-3)
    yaw = math.atan2(reading.pose.rotation[1, 0], reading.pose.rotation[0, 0])
    assert yaw == pytest.approx(turned, abs=1e-9)
    np.testing.assert_allclose(reading.linear, [speed, 0, 0], atol=1e-9)
    np.testing.assert_allclose(reading.angular, [0, 0, turn_rate], atol=1e-9)
    # And exactly the ground truth, re-expressed in the start frame.
    c, s = math.cos(start_yaw), math.sin(start_yaw)
    world_offset = data.xpos[model.body("base_link").id] - np.array([1.0, 2.0, 0.1])
    np.testing.assert_allclose(
        reading.pose.position[:2],
        [c * world_offset[0] + s * world_offset[1], -s * world_offset[0] + c * world_offset[1]],
        atol=1e-12,
    )


def test_odometry_messages_and_tf():
    model = mujoco.MjModel.from_xml_string(BASE_SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    odom = Odometry(model, OdometryConfig(name="odom", body="base_link", origin="world"))
    drive(model, data, 1.0, 0.0, 0.5)
    messages = {pub.topic: pub for pub in odom.measure(model, data)}
    msg = messages["odom"].message
    assert messages["odom"].msgtype == "nav_msgs/Odometry"
    assert (msg.header.frame_id, msg.child_frame_id) == ("odom", "base_link")
    assert msg.pose.pose.position.x == pytest.approx(1.5, abs=1e-9)
    assert msg.pose.pose.position.y == pytest.approx(2.0, abs=1e-9)
    assert msg.twist.twist.linear.x == pytest.approx(1.0)
    assert msg.header.stamp.sec == 0
    assert msg.header.stamp.nanosec == 500_000_000
    tf = messages["/tf"]
    assert tf.msgtype == "tf2_msgs/TFMessage"
    (transform,) = tf.message.transforms
    assert (transform.header.frame_id, transform.child_frame_id) == ("odom", "base_link")
    assert transform.transform.translation.x == pytest.approx(1.5, abs=1e-9)
    assert odom.static_frame(model) is None


def test_odometry_of_an_offset_mount_sees_the_lever_arm(imu_world):
    model, data = imu_world
    omega, radius = 2.0, 0.4
    odom = Odometry(
        model,
        OdometryConfig(
            name="odom", body="turntable", xyz=(radius, 0.0, 0.0), rpy=(0.0, 0.0, math.pi / 2)
        ),
    )
    data.qvel[model.joint("spin").dofadr[0]] = omega
    mujoco.mj_forward(model, data)
    reading = odom.read(model, data)
    # The mount is yawed +90 deg: its x axis is the rim's direction of travel.
    np.testing.assert_allclose(reading.linear, [omega * radius, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(reading.angular, [0.0, 0.0, omega], atol=1e-12)
