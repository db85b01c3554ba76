"""All sensors of a scene: built from config dictionaries, polled after each physics step."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import mujoco

from simbridge.errors import SimError, did_you_mean
from simbridge.sim.sensors.base import Sensor
from simbridge.sim.sensors.camera import Camera, CameraConfig
from simbridge.sim.sensors.config import SensorConfig
from simbridge.sim.sensors.depth_camera import DepthCamera, DepthCameraConfig
from simbridge.sim.sensors.imu import Imu, ImuConfig
from simbridge.sim.sensors.lidar2d import Lidar2D, Lidar2DConfig
from simbridge.sim.sensors.lidar3d import Lidar3D, Lidar3DConfig
from simbridge.sim.sensors.odometry import Odometry, OdometryConfig
from simbridge.sim.sensors.rosmsg import Publication, transform_stamped

__all__ = ["SENSOR_CONFIGS", "SENSOR_TYPES", "SensorSuite", "build_sensor", "sensor_config"]


def _lidar2d(model: mujoco.MjModel, cfg: Mapping[str, Any]) -> Sensor:
    return Lidar2D(model, Lidar2DConfig.from_config(cfg))


def _lidar3d(model: mujoco.MjModel, cfg: Mapping[str, Any]) -> Sensor:
    return Lidar3D(model, Lidar3DConfig.from_config(cfg))


def _camera(model: mujoco.MjModel, cfg: Mapping[str, Any]) -> Sensor:
    return Camera(model, CameraConfig.from_config(cfg))


def _depth(model: mujoco.MjModel, cfg: Mapping[str, Any]) -> Sensor:
    return DepthCamera(model, DepthCameraConfig.from_config(cfg))


def _imu(model: mujoco.MjModel, cfg: Mapping[str, Any]) -> Sensor:
    return Imu(model, ImuConfig.from_config(cfg))


def _odometry(model: mujoco.MjModel, cfg: Mapping[str, Any]) -> Sensor:
    return Odometry(model, OdometryConfig.from_config(cfg))


SENSOR_TYPES: dict[str, Callable[[mujoco.MjModel, Mapping[str, Any]], Sensor]] = {
    "lidar_2d": _lidar2d,
    "lidar_3d": _lidar3d,
    "camera": _camera,
    "depth_camera": _depth,
    "imu": _imu,
    "odometry": _odometry,
}


SENSOR_CONFIGS: dict[str, type[SensorConfig]] = {
    "lidar_2d": Lidar2DConfig,
    "lidar_3d": Lidar3DConfig,
    "camera": CameraConfig,
    "depth_camera": DepthCameraConfig,
    "imu": ImuConfig,
    "odometry": OdometryConfig,
}


def _kind(config: Mapping[str, Any]) -> str:
    kind = config.get("type")
    if not isinstance(kind, str) or kind not in SENSOR_CONFIGS:
        raise SimError(
            f"sensor {config.get('name', '?')!r}: unknown type {kind!r}"
            f"{did_you_mean(str(kind), SENSOR_CONFIGS)} (valid: {', '.join(SENSOR_CONFIGS)})"
        )
    return kind


def sensor_config(config: Mapping[str, Any]) -> SensorConfig:
    """Check a scene-file sensor entry without a model (its type, options and their types)
    and return its options: a scene checks every entry so when it loads."""
    return SENSOR_CONFIGS[_kind(config)].from_config(config)


def build_sensor(model: mujoco.MjModel, config: Mapping[str, Any]) -> Sensor:
    """Create one sensor from a scene-file mapping whose `type` is a key of SENSOR_TYPES."""
    return SENSOR_TYPES[_kind(config)](model, config)


class SensorSuite:
    """The sensors of one simulation; `poll` after every physics step returns what is due."""

    def __init__(self, sensors: Iterable[Sensor] = ()) -> None:
        self.sensors: list[Sensor] = []
        for sensor in sensors:
            self.add(sensor)

    @classmethod
    def from_config(
        cls, model: mujoco.MjModel, configs: Sequence[Mapping[str, Any]]
    ) -> SensorSuite:
        """Build every sensor listed in a scene file's `sensors:` section."""
        return cls(build_sensor(model, config) for config in configs)

    def add(self, sensor: Sensor) -> None:
        """Add a sensor; names and topics must be unique across the suite."""
        if any(existing.name == sensor.name for existing in self.sensors):
            raise SimError(f"two sensors are named {sensor.name!r}")
        taken = {topic for existing in self.sensors for topic in existing.outputs}
        clash = sorted(taken & set(sensor.outputs))
        if clash:
            raise SimError(f"sensor {sensor.name!r} publishes on topics already used: {clash}")
        self.sensors.append(sensor)

    def __getitem__(self, name: str) -> Sensor:
        for sensor in self.sensors:
            if sensor.name == name:
                return sensor
        raise SimError(
            f"no sensor named {name!r}; sensors: {[sensor.name for sensor in self.sensors]}"
        )

    @property
    def outputs(self) -> dict[str, str]:
        """Every topic any sensor can publish -> its ROS 1 message type."""
        return {topic: kind for sensor in self.sensors for topic, kind in sensor.outputs.items()}

    def set_wanted(self, topic: str, wanted: bool) -> None:
        """Switch the output `topic` on or off (the ROS layer follows subscriptions)."""
        for sensor in self.sensors:
            if topic in sensor.outputs:
                sensor.set_wanted(topic, wanted)
                return
        raise SimError(f"no sensor publishes {topic!r}; topics: {sorted(self.outputs)}")

    def static_transforms(self, model: mujoco.MjModel) -> list[Any]:
        """geometry_msgs/TransformStamped for /tf_static: every sensor data frame that is
        not a model body (offset mounts, camera optical frames), stamped at time 0."""
        frames = (sensor.static_frame(model) for sensor in self.sensors)
        return [
            transform_stamped(0.0, parent, child, pose)
            for parent, child, pose in (frame for frame in frames if frame is not None)
        ]

    def poll(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        refresh: Callable[[], None] | None = None,
    ) -> list[Publication]:
        """Messages from every sensor due at `data.time`.

        After `mj_step` MuJoCo's derived quantities (body poses, velocities,
        accelerations) still describe the state before the step, one step behind
        `data.time`. So when a reading is due `refresh()` runs first to bring them up
        to date (`mj_forward` by default; a `World` passes its own, which runs at most
        once per step), and every reading describes the state at its stamp.
        """
        due = [sensor for sensor in self.sensors if sensor.due(model, data)]
        if not due:
            return []
        if refresh is None:
            mujoco.mj_forward(model, data)
        else:
            refresh()
        return [pub for sensor in due for pub in sensor.measure(model, data)]

    def reset(self) -> None:
        """Restart every schedule after the simulation was reset."""
        for sensor in self.sensors:
            sensor.reset()

    def close(self) -> None:
        """Release every sensor's resources."""
        for sensor in self.sensors:
            sensor.close()
