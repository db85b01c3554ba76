"""Sensor readings in observations, from the same sensor classes that publish to ROS.

A `LidarRanges` entry is `Lidar2D.scan` (what `/scan` carries) made finite for a `Box`;
a `CameraImage` entry is `Camera.render` (what `image_raw` carries) at the size you ask.
Both take a sensor of the scene by name, or a config of their own.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from typing import Any

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from simbridge.errors import GymError
from simbridge.sim.sensors import Camera, CameraConfig, Lidar2D, Lidar2DConfig
from simbridge.sim.world import World

__all__ = ["CameraImage", "LidarRanges", "SensorObservation", "finite_ranges"]


def _scene_sensor(world: World, name: str, kind: str) -> dict[str, Any]:
    for entry in world.scene.sensors:
        if entry.get("name") == name:
            if entry.get("type") != kind:
                raise GymError(f"scene sensor {name!r} is a {entry.get('type')!r}, not a {kind}")
            return dict(entry)
    names = [entry.get("name") for entry in world.scene.sensors]
    raise GymError(f"the scene has no sensor {name!r} (sensors: {names})")


def finite_ranges(
    ranges: NDArray[np.floating[Any]], range_min: float, range_max: float
) -> NDArray[np.float32]:
    """REP 117 ranges made finite: no return (+inf) -> range_max, too close (-inf) -> 0."""
    out = np.nan_to_num(np.asarray(ranges, np.float32), posinf=range_max, neginf=0.0, nan=0.0)
    return np.clip(out, 0.0, range_max).astype(np.float32)


class SensorObservation(ABC):
    """One observation entry computed by a simulated sensor."""

    key: str
    space: spaces.Box

    @abstractmethod
    def bind(self, world: World) -> None:
        """Build the sensor on the world's model (and fix `space`)."""

    @abstractmethod
    def read(self, world: World) -> NDArray[Any]:
        """The reading for the world's current state."""

    def close(self) -> None:  # noqa: B027 - optional hook
        """Release resources (renderers)."""


class LidarRanges(SensorObservation):
    """2D lidar ranges (m), one per beam, in [0, range_max] (see `finite_ranges`)."""

    def __init__(self, sensor: str | Lidar2DConfig, key: str = "lidar") -> None:
        self.sensor, self.key = sensor, key
        self.lidar: Lidar2D | None = None

    def bind(self, world: World) -> None:
        """Build the `Lidar2D` (noise seeded by its config, as on the ROS side)."""
        config = self.sensor
        if isinstance(config, str):
            config = Lidar2DConfig.from_config(_scene_sensor(world, config, "lidar_2d"))
        self.lidar = Lidar2D(world.model, config)
        self.space = spaces.Box(0.0, config.range_max, (config.samples,), np.float32)

    def read(self, world: World) -> NDArray[np.float32]:
        """One scan now."""
        assert self.lidar is not None, "bind() first"
        cfg = self.lidar.config
        ranges = self.lidar.scan(world.model, world.data).ranges
        return finite_ranges(ranges, cfg.range_min, cfg.range_max)


class CameraImage(SensorObservation):
    """An RGB image, uint8 (height, width, 3), rendered offscreen (OSMesa or EGL)."""

    def __init__(
        self,
        sensor: str | CameraConfig,
        key: str = "image",
        width: int | None = None,
        height: int | None = None,
    ) -> None:
        self.sensor, self.key, self.width, self.height = sensor, key, width, height
        self.camera: Camera | None = None

    def bind(self, world: World) -> None:
        """Build the `Camera` at the requested size."""
        config = self.sensor
        if isinstance(config, str):
            entry = _scene_sensor(world, config, "camera")
            config = CameraConfig.from_config(entry)
        config = dataclasses.replace(
            config, width=self.width or config.width, height=self.height or config.height
        )
        self.camera = Camera(world.model, config)
        self.space = spaces.Box(0, 255, (config.height, config.width, 3), np.uint8)

    def read(self, world: World) -> NDArray[np.uint8]:
        """Render one frame now."""
        assert self.camera is not None, "bind() first"
        return self.camera.render(world.model, world.data)

    def close(self) -> None:
        """Free the renderer."""
        if self.camera is not None:
            self.camera.close()
