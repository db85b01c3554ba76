"""Ground-truth wheel-odometry stand-in: nav_msgs/Odometry plus odom -> base on /tf."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import SimError
from simbridge.sim.sensors.base import Sensor
from simbridge.sim.sensors.config import SensorConfig
from simbridge.sim.sensors.frames import Pose
from simbridge.sim.sensors.rosmsg import (
    Publication,
    header,
    new_message,
    pose_message,
    transform_stamped,
    vector3,
)
from simbridge.sim.urdf.transforms import rpy_to_matrix

__all__ = [
    "DEFAULT_POSE_COVARIANCE",
    "DEFAULT_TWIST_COVARIANCE",
    "Odometry",
    "OdometryConfig",
    "OdometryReading",
]

ODOM_ORIGINS = ("initial", "world")

Vec6 = tuple[float, float, float, float, float, float]
DEFAULT_POSE_COVARIANCE: Vec6 = (1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4)
"""x, y, z (m^2), roll, pitch, yaw (rad^2): 1 cm and 0.6 degree standard deviations."""
DEFAULT_TWIST_COVARIANCE: Vec6 = (1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4)
"""vx, vy, vz ((m/s)^2), wx, wy, wz ((rad/s)^2): 1 cm/s and 0.6 degree/s."""


@dataclass(frozen=True, kw_only=True)
class OdometryConfig(SensorConfig):
    """Odometry of the mount body (the mobile base) per REP 105.

    `origin` "initial": the odom frame is the base's first pose, levelled (yaw only);
    "world": odom coincides with the world frame. `frame_id` is the odom frame (default
    `odom`), `child_frame_id` the base frame (default: the body). Default topic `odom`.
    `pose_covariance_diagonal` and `twist_covariance_diagonal` (names as in ROS's
    diff_drive_controller) are the diagonals of the published 6x6 covariances: how far a
    consumer such as robot_localization should trust the readings (all-zero
    covariances, which claim perfect readings, are rejected there).
    """

    rate: float = 50.0
    child_frame_id: str = ""
    origin: str = "initial"
    publish_tf: bool = True
    tf_topic: str = "/tf"
    pose_covariance_diagonal: Vec6 = DEFAULT_POSE_COVARIANCE
    twist_covariance_diagonal: Vec6 = DEFAULT_TWIST_COVARIANCE


@dataclass(frozen=True)
class OdometryReading:
    """Base pose in the odom frame; twist (angular, linear) in the base frame."""

    pose: Pose
    angular: NDArray[np.float64]
    linear: NDArray[np.float64]


class Odometry(Sensor):
    """Reports the base's exact pose and body-frame twist relative to a fixed odom frame."""

    def __init__(self, model: mujoco.MjModel, config: OdometryConfig) -> None:
        if config.origin not in ODOM_ORIGINS:
            raise SimError(
                f"odometry {config.name!r}: origin {config.origin!r} is not one of {ODOM_ORIGINS}"
            )
        for key in ("pose_covariance_diagonal", "twist_covariance_diagonal"):
            values = getattr(config, key)
            if not all(math.isfinite(v) and v > 0 for v in values):
                raise SimError(
                    f"odometry {config.name!r}: {key} needs 6 finite variances > 0 "
                    f"(x, y, z, then rotation about x, y, z), got {list(values)}"
                )
        self.config = config
        self.pose_covariance = np.diag(config.pose_covariance_diagonal).ravel()
        self.twist_covariance = np.diag(config.twist_covariance_diagonal).ravel()
        self.topic = config.topic or "odom"
        self.child_frame_id = config.child_frame_id or config.body or "world"
        outputs = {self.topic: "nav_msgs/Odometry"}
        if config.publish_tf:
            outputs[config.tf_topic] = "tf2_msgs/TFMessage"
        super().__init__(
            config.name,
            config.mount().resolve(model),
            config.rate,
            frame_id=config.frame_id or "odom",
            outputs=outputs,
        )
        self._odom_in_world: Pose | None = None

    def reset(self) -> None:
        """Restart the schedule and re-anchor the odom frame at the next reading."""
        super().reset()
        self._odom_in_world = None

    def static_frame(self, model: mujoco.MjModel) -> tuple[str, str, Pose] | None:
        """Odometry's frame is dynamic (published on /tf), never static."""
        return None

    def read(self, model: mujoco.MjModel, data: mujoco.MjData) -> OdometryReading:
        """Base pose in odom and its twist in the base frame (at the mount point)."""
        base = self.world_pose(data)
        if self._odom_in_world is None:
            if self.config.origin == "world":
                self._odom_in_world = Pose(np.zeros(3), np.eye(3))
            else:
                yaw = math.atan2(base.rotation[1, 0], base.rotation[0, 0])
                self._odom_in_world = Pose(base.position.copy(), rpy_to_matrix((0, 0, yaw)))
        velocity = np.zeros(6)
        body = self.frame.body_id
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, body, velocity, 1)
        offset = self.frame.offset
        # Rigid-body transport from the body origin to the mount point, then into its axes.
        omega_body = velocity[:3]
        linear_body = velocity[3:] + np.cross(omega_body, offset.position)
        return OdometryReading(
            self._odom_in_world.inverse().compose(base),
            offset.rotation.T @ omega_body,
            offset.rotation.T @ linear_body,
        )

    def measure(self, model: mujoco.MjModel, data: mujoco.MjData) -> list[Publication]:
        """Publish nav_msgs/Odometry and, when enabled, the odom -> base transform."""
        reading = self.read(model, data)
        now = float(data.time)
        out: list[Publication] = []
        if self.wanted(self.topic):
            message = new_message(
                "nav_msgs/Odometry",
                header=header(now, self.frame_id, self._next_seq(self.topic)),
                child_frame_id=self.child_frame_id,
                pose=new_message(
                    "geometry_msgs/PoseWithCovariance",
                    pose=pose_message(reading.pose),
                    covariance=self.pose_covariance.copy(),
                ),
                twist=new_message(
                    "geometry_msgs/TwistWithCovariance",
                    twist=new_message(
                        "geometry_msgs/Twist",
                        linear=vector3(reading.linear),
                        angular=vector3(reading.angular),
                    ),
                    covariance=self.twist_covariance.copy(),
                ),
            )
            out.append(self._publication(self.topic, message))
        if self.config.publish_tf and self.wanted(self.config.tf_topic):
            transform = transform_stamped(now, self.frame_id, self.child_frame_id, reading.pose)
            out.append(
                self._publication(
                    self.config.tf_topic, new_message("tf2_msgs/TFMessage", transforms=[transform])
                )
            )
        return out
