"""IMU publishing sensor_msgs/Imu: orientation, angular velocity, proper acceleration."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.sim.sensors.base import Sensor
from simbridge.sim.sensors.config import SensorConfig
from simbridge.sim.sensors.frames import quat_wxyz_from_matrix
from simbridge.sim.sensors.rosmsg import Publication, header, new_message, quaternion, vector3

__all__ = ["Imu", "ImuConfig", "ImuReading"]


@dataclass(frozen=True, kw_only=True)
class ImuConfig(SensorConfig):
    """Gaussian white noise (stddev per axis) and constant biases drawn once from
    N(0, *_bias_stddev) with `seed`. Default topic `imu`, default rate 100 Hz."""

    rate: float = 100.0
    gyro_noise: float = 0.0
    accel_noise: float = 0.0
    orientation_noise: float = 0.0
    gyro_bias_stddev: float = 0.0
    accel_bias_stddev: float = 0.0
    seed: int = 0


@dataclass(frozen=True)
class ImuReading:
    """Orientation (w, x, y, z) of the sensor in the world, and angular velocity (rad/s)
    and proper acceleration (m/s^2, reads +g upward at rest) in the sensor frame."""

    orientation_wxyz: NDArray[np.float64]
    angular_velocity: NDArray[np.float64]
    linear_acceleration: NDArray[np.float64]


class Imu(Sensor):
    """Reads the mount point's kinematics from MuJoCo's body accelerations (with gravity)."""

    def __init__(self, model: mujoco.MjModel, config: ImuConfig) -> None:
        self.config = config
        self.topic = config.topic or "imu"
        super().__init__(
            config.name,
            config.mount().resolve(model),
            config.rate,
            frame_id=config.resolved_frame_id(),
            outputs={self.topic: "sensor_msgs/Imu"},
        )
        self._rng = np.random.default_rng(config.seed)
        self.gyro_bias = self._rng.normal(0.0, config.gyro_bias_stddev, 3)
        self.accel_bias = self._rng.normal(0.0, config.accel_bias_stddev, 3)

    def read(self, model: mujoco.MjModel, data: mujoco.MjData) -> ImuReading:
        """Current reading including noise and bias."""
        cfg = self.config
        body = self.frame.body_id
        mujoco.mj_rnePostConstraint(model, data)
        velocity = np.zeros(6)
        acceleration = np.zeros(6)
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, body, velocity, 0)
        mujoco.mj_objectAcceleration(model, data, mujoco.mjtObj.mjOBJ_XBODY, body, acceleration, 0)
        omega, alpha, origin_acc = velocity[:3], acceleration[:3], acceleration[3:]
        lever = np.array(data.xmat[body]).reshape(3, 3) @ self.frame.offset.position
        point_acc = origin_acc + np.cross(alpha, lever) + np.cross(omega, np.cross(omega, lever))
        pose = self.world_pose(data)
        to_sensor = pose.rotation.T
        gyro = to_sensor @ omega + self.gyro_bias + self._rng.normal(0.0, cfg.gyro_noise, 3)
        accel = to_sensor @ point_acc + self.accel_bias + self._rng.normal(0.0, cfg.accel_noise, 3)
        rotation = pose.rotation
        if cfg.orientation_noise > 0:
            tilt = self._rng.normal(0.0, cfg.orientation_noise, 3)
            rotation = rotation @ _rotation_from_vector(tilt)
        return ImuReading(quat_wxyz_from_matrix(rotation), gyro, accel)

    def measure(self, model: mujoco.MjModel, data: mujoco.MjData) -> list[Publication]:
        """Publish one sensor_msgs/Imu with diagonal covariances from the noise settings."""
        reading = self.read(model, data)
        cfg = self.config
        message = new_message(
            "sensor_msgs/Imu",
            header=header(float(data.time), self.frame_id, self._next_seq(self.topic)),
            orientation=quaternion(reading.orientation_wxyz),
            orientation_covariance=_diagonal(cfg.orientation_noise),
            angular_velocity=vector3(reading.angular_velocity),
            angular_velocity_covariance=_diagonal(cfg.gyro_noise),
            linear_acceleration=vector3(reading.linear_acceleration),
            linear_acceleration_covariance=_diagonal(cfg.accel_noise),
        )
        return [self._publication(self.topic, message)]


def _diagonal(stddev: float) -> NDArray[np.float64]:
    return (np.eye(3) * stddev**2).ravel()


def _rotation_from_vector(rotvec: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrix of a rotation vector (axis * angle), by Rodrigues' formula."""
    angle = float(np.linalg.norm(rotvec))
    if angle == 0.0:
        return np.eye(3)
    k = rotvec / angle
    skew = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    rotation: NDArray[np.float64] = np.eye(3) + np.sin(angle) * skew
    rotation += (1 - np.cos(angle)) * (skew @ skew)
    return rotation
