"""Simulated sensors (lidar, cameras, depth, IMU, odometry) publishing ROS messages.

Sensors work on a `mujoco.MjModel`/`MjData` pair and a mount (body + offset), run at
their own rate in simulated time and do no work while none of their outputs is wanted.
"""

from simbridge.sim.sensors.base import Sensor
from simbridge.sim.sensors.binding import SteppedWorld, attach_sensors
from simbridge.sim.sensors.camera import Camera, CameraConfig
from simbridge.sim.sensors.camera_model import PinholeModel, optical_pose
from simbridge.sim.sensors.config import SensorConfig
from simbridge.sim.sensors.depth_camera import DepthCamera, DepthCameraConfig
from simbridge.sim.sensors.frames import Mount, MountedFrame, Pose
from simbridge.sim.sensors.gl_backend import configure_gl
from simbridge.sim.sensors.imu import Imu, ImuConfig, ImuReading
from simbridge.sim.sensors.lidar2d import LaserScanResult, Lidar2D, Lidar2DConfig
from simbridge.sim.sensors.lidar3d import Lidar3D, Lidar3DConfig, PointScan
from simbridge.sim.sensors.odometry import Odometry, OdometryConfig, OdometryReading
from simbridge.sim.sensors.offscreen import OffscreenRenderer
from simbridge.sim.sensors.raycast import RayCaster, RayHits
from simbridge.sim.sensors.rosmsg import Publication
from simbridge.sim.sensors.schedule import RateSchedule
from simbridge.sim.sensors.suite import SENSOR_TYPES, SensorSuite, build_sensor

__all__ = [
    "SENSOR_TYPES",
    "Camera",
    "CameraConfig",
    "DepthCamera",
    "DepthCameraConfig",
    "Imu",
    "ImuConfig",
    "ImuReading",
    "LaserScanResult",
    "Lidar2D",
    "Lidar2DConfig",
    "Lidar3D",
    "Lidar3DConfig",
    "Mount",
    "MountedFrame",
    "Odometry",
    "OdometryConfig",
    "OdometryReading",
    "OffscreenRenderer",
    "PinholeModel",
    "PointScan",
    "Pose",
    "Publication",
    "RateSchedule",
    "RayCaster",
    "RayHits",
    "Sensor",
    "SensorConfig",
    "SensorSuite",
    "SteppedWorld",
    "attach_sensors",
    "build_sensor",
    "configure_gl",
    "optical_pose",
]
