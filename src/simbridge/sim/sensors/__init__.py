"""Simulated sensors (lidar, cameras, depth, IMU, odometry) publishing ROS messages.

Sensors work on a `mujoco.MjModel`/`MjData` pair and a mount (body + offset), run at
their own rate in simulated time and do no work while none of their outputs is wanted.
A scene's `sensors:` list maps onto `SensorSuite.from_config` / `attach_sensors`:

    sensors:
      - {type: lidar_2d, name: front_laser, body: laser_link, rate: 10, samples: 360,
         range_min: 0.1, range_max: 12, noise_stddev: 0.01}
      - {type: lidar_3d, name: velodyne, body: base_link, xyz: [0, 0, 0.4], channels: 16,
         samples: 1800, rate: 10}
      - {type: camera, name: front_cam, body: camera_link, width: 640, height: 480,
         fovy: 1.047, rate: 10, compression: jpeg, jpeg_quality: 80,
         labelers: [instance, semantic, boxes_2d]}
      - {type: depth_camera, name: depth, body: camera_link, topic: camera, range_max: 8}
      - {type: imu, name: imu, body: base_link, rate: 100, accel_noise: 0.02}
      - {type: odometry, name: odom, body: base_link, rate: 50}

Every entry takes name, body, xyz, rpy (URDF style), rate (Hz), frame_id and topic; the
per-type options are the fields of the matching *Config class.
"""

from simbridge.sim.sensors.base import Sensor
from simbridge.sim.sensors.binding import SteppedWorld, attach_sensors
from simbridge.sim.sensors.camera import Camera, CameraConfig
from simbridge.sim.sensors.camera_model import PinholeModel, optical_pose
from simbridge.sim.sensors.config import OptionError, SensorConfig
from simbridge.sim.sensors.depth_camera import DepthCamera, DepthCameraConfig
from simbridge.sim.sensors.frames import Mount, MountedFrame, Pose
from simbridge.sim.sensors.gl_backend import configure_gl
from simbridge.sim.sensors.imu import Imu, ImuConfig, ImuReading
from simbridge.sim.sensors.labelled import LIVE_LABELERS, Detection, LabelLookup, LiveLabeller
from simbridge.sim.sensors.lidar2d import LaserScanResult, Lidar2D, Lidar2DConfig
from simbridge.sim.sensors.lidar3d import Lidar3D, Lidar3DConfig, PointScan
from simbridge.sim.sensors.odometry import Odometry, OdometryConfig, OdometryReading
from simbridge.sim.sensors.offscreen import OffscreenRenderer
from simbridge.sim.sensors.raycast import RayCaster, RayHits
from simbridge.sim.sensors.rosmsg import Publication
from simbridge.sim.sensors.schedule import RateSchedule
from simbridge.sim.sensors.suite import (
    SENSOR_CONFIGS,
    SENSOR_TYPES,
    SensorSuite,
    build_sensor,
    sensor_config,
)

__all__ = [
    "LIVE_LABELERS",
    "SENSOR_CONFIGS",
    "SENSOR_TYPES",
    "Camera",
    "CameraConfig",
    "DepthCamera",
    "DepthCameraConfig",
    "Detection",
    "Imu",
    "ImuConfig",
    "ImuReading",
    "LabelLookup",
    "LaserScanResult",
    "Lidar2D",
    "Lidar2DConfig",
    "Lidar3D",
    "Lidar3DConfig",
    "LiveLabeller",
    "Mount",
    "MountedFrame",
    "Odometry",
    "OdometryConfig",
    "OdometryReading",
    "OffscreenRenderer",
    "OptionError",
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
    "sensor_config",
]
