"""Multi-beam 3D lidar publishing sensor_msgs/PointCloud2 (x, y, z, intensity, ring)."""

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
from simbridge.sim.sensors.rosmsg import Publication, header, point_cloud2

__all__ = ["POINT_DTYPE", "Lidar3D", "Lidar3DConfig", "PointScan"]

# Velodyne-style record: float32 x, y, z, intensity, then uint16 ring, packed little-endian.
POINT_DTYPE = np.dtype(
    {
        "names": ["x", "y", "z", "intensity", "ring"],
        "formats": ["<f4", "<f4", "<f4", "<f4", "<u2"],
        "offsets": [0, 4, 8, 12, 16],
        "itemsize": 18,
    }
)


@dataclass(frozen=True, kw_only=True)
class Lidar3DConfig(SensorConfig):
    """`channels` beams from vertical_min to vertical_max (rad), each swept over `samples`
    azimuths from angle_min to angle_max. Ring 0 is the lowest beam. Default topic `points`.
    `threads`: ray-casting worker threads (0: one per CPU, 1: cast on the calling thread).
    `ignore_bodies` and `geomgroup` work as for Lidar2DConfig.
    """

    channels: int = 16
    vertical_min: float = -math.radians(15.0)
    vertical_max: float = math.radians(15.0)
    samples: int = 1800
    angle_min: float = -math.pi
    angle_max: float = math.pi - 2 * math.pi / 1800
    range_min: float = 0.3
    range_max: float = 100.0
    noise_stddev: float = 0.0
    seed: int = 0
    geomgroup: tuple[int, ...] | None = None
    ignore_bodies: tuple[str, ...] = ()
    threads: int = 1


@dataclass(frozen=True)
class PointScan:
    """Returns within [range_min, range_max]: points in the sensor frame, intensity, ring."""

    points: NDArray[np.float32]
    intensity: NDArray[np.float32]
    ring: NDArray[np.uint16]


class Lidar3D(Sensor):
    """Spinning multi-beam lidar, modelled as one instantaneous batched ray cast per sweep."""

    def __init__(self, model: mujoco.MjModel, config: Lidar3DConfig) -> None:
        if config.channels < 1 or config.samples < 1:
            raise SimError(
                f"lidar {config.name!r}: channels and samples must be >= 1, got "
                f"{config.channels} x {config.samples}"
            )
        check_range_limits(config.name, config.range_min, config.range_max)
        frame = config.mount().resolve(model)
        self.config = config
        self.topic = config.topic or "points"
        super().__init__(
            config.name,
            frame,
            config.rate,
            frame_id=config.resolved_frame_id(),
            outputs={self.topic: "sensor_msgs/PointCloud2"},
        )
        elevation = np.linspace(config.vertical_min, config.vertical_max, config.channels)
        azimuth = np.linspace(config.angle_min, config.angle_max, config.samples)
        elev, azim = np.meshgrid(elevation, azimuth, indexing="ij")
        directions = np.stack(
            [np.cos(elev) * np.cos(azim), np.cos(elev) * np.sin(azim), np.sin(elev)], axis=-1
        ).reshape(-1, 3)
        self._rings = np.repeat(np.arange(config.channels, dtype=np.uint16), config.samples)
        self._beams = LidarBeams(model, directions, frame, config, threads=config.threads)

    @property
    def beam_count(self) -> int:
        """Rays cast per sweep (channels x samples)."""
        return len(self._beams)

    def scan(self, model: mujoco.MjModel, data: mujoco.MjData) -> PointScan:
        """Cast every beam now; keep returns inside the range limits."""
        hits = self._beams.cast(model, data, self.world_pose(data))
        distance = hits.distance
        keep = (distance >= self.config.range_min) & (distance <= self.config.range_max)
        points = self._beams.directions[keep] * distance[keep, None]
        return PointScan(
            points.astype(np.float32),
            hits.cos_incidence[keep].astype(np.float32),
            self._rings[keep],
        )

    def measure(self, model: mujoco.MjModel, data: mujoco.MjData) -> list[Publication]:
        """Publish the sweep as an unorganised, dense PointCloud2."""
        result = self.scan(model, data)
        records = np.empty(len(result.points), dtype=POINT_DTYPE)
        records["x"] = result.points[:, 0]
        records["y"] = result.points[:, 1]
        records["z"] = result.points[:, 2]
        records["intensity"] = result.intensity
        records["ring"] = result.ring
        message = point_cloud2(
            header(float(data.time), self.frame_id, self._next_seq(self.topic)),
            records,
            height=1,
            width=len(records),
        )
        return [self._publication(self.topic, message)]

    def close(self) -> None:
        """Stop the ray-casting worker threads."""
        self._beams.close()
