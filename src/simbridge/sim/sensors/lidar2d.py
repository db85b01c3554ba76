"""2D scanning lidar publishing sensor_msgs/LaserScan with REP 117 range semantics."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import SimError
from simbridge.sim.sensors.base import Sensor
from simbridge.sim.sensors.beams import LidarBeams
from simbridge.sim.sensors.config import SensorConfig
from simbridge.sim.sensors.raycast import check_range_limits
from simbridge.sim.sensors.rosmsg import Publication, header, new_message

__all__ = ["LaserScanResult", "Lidar2D", "Lidar2DConfig", "apply_range_limits"]


@dataclass(frozen=True, kw_only=True)
class Lidar2DConfig(SensorConfig):
    """A planar scan in the mount's x-y plane, counter-clockwise from angle_min to angle_max.

    Default topic `scan`; default frame the mount body. Noise is Gaussian on range (m).
    Beams see through the mount body and `ignore_bodies` (e.g. the robot's other links);
    `geomgroup` (6 flags) defaults to the groups holding collision geoms.
    """

    angle_min: float = -math.pi
    angle_max: float = math.pi - 2 * math.pi / 360
    samples: int = 360
    range_min: float = 0.1
    range_max: float = 30.0
    noise_stddev: float = 0.0
    intensities: bool = False
    seed: int = 0
    geomgroup: tuple[int, ...] | None = None
    ignore_bodies: tuple[str, ...] = ()


@dataclass(frozen=True)
class LaserScanResult:
    """Ranges per REP 117 (+inf no return, -inf closer than range_min) and intensities."""

    ranges: NDArray[np.float32]
    intensities: NDArray[np.float32]


def apply_range_limits(
    distance: NDArray[np.float64], range_min: float, range_max: float
) -> NDArray[np.float64]:
    """REP 117: beyond range_max or no hit -> +inf, below range_min -> -inf."""
    out = np.where(distance > range_max, np.inf, distance)
    return np.where(out < range_min, -np.inf, out)


class Lidar2D(Sensor):
    """Planar lidar: one batched ray cast per scan against the collision geometry."""

    def __init__(self, model: mujoco.MjModel, config: Lidar2DConfig) -> None:
        if config.samples < 2 or not config.angle_max > config.angle_min:
            raise SimError(
                f"lidar {config.name!r}: needs samples >= 2 and angle_max > angle_min, got "
                f"samples={config.samples}, angles [{config.angle_min}, {config.angle_max}]"
            )
        check_range_limits(config.name, config.range_min, config.range_max)
        frame = config.mount().resolve(model)
        self.config = config
        self.topic = config.topic or "scan"
        super().__init__(
            config.name,
            frame,
            config.rate,
            frame_id=config.resolved_frame_id(),
            outputs={self.topic: "sensor_msgs/LaserScan"},
        )
        self.angles = np.linspace(config.angle_min, config.angle_max, config.samples)
        directions = np.stack(
            [np.cos(self.angles), np.sin(self.angles), np.zeros_like(self.angles)], axis=1
        )
        self._beams = LidarBeams(model, directions, frame, config)

    @property
    def angle_increment(self) -> float:
        """Angle between consecutive beams (radians)."""
        return float(self.angles[1] - self.angles[0])

    def scan(self, model: mujoco.MjModel, data: mujoco.MjData) -> LaserScanResult:
        """Cast all beams now and return REP 117 ranges and |cos(incidence)| intensities."""
        hits = self._beams.cast(model, data, self.world_pose(data))
        ranges = apply_range_limits(hits.distance, self.config.range_min, self.config.range_max)
        intensities = np.where(np.isfinite(ranges), hits.cos_incidence, 0.0)
        return LaserScanResult(ranges.astype(np.float32), intensities.astype(np.float32))

    def measure(self, model: mujoco.MjModel, data: mujoco.MjData) -> list[Publication]:
        """Publish one LaserScan stamped with the current sim time."""
        result = self.scan(model, data)
        cfg = self.config
        message = new_message(
            "sensor_msgs/LaserScan",
            header=header(float(data.time), self.frame_id, self._next_seq(self.topic)),
            angle_min=float(self.angles[0]),
            angle_max=float(self.angles[-1]),
            angle_increment=self.angle_increment,
            time_increment=0.0,
            scan_time=self.schedule.period,
            range_min=cfg.range_min,
            range_max=cfg.range_max,
            ranges=result.ranges,
            intensities=result.intensities if cfg.intensities else np.zeros(0, np.float32),
        )
        return [self._publication(self.topic, message)]
