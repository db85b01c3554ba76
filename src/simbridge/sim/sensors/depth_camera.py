"""Depth camera: 32FC1 metres (REP 118), 16UC1 millimetres, PointCloud2 and CameraInfo."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import SimError
from simbridge.sim.sensors.base import Sensor
from simbridge.sim.sensors.camera_model import OPTICAL_FROM_BODY, PinholeModel
from simbridge.sim.sensors.config import SensorConfig
from simbridge.sim.sensors.frames import Pose
from simbridge.sim.sensors.lazy_renderer import LazyRenderer
from simbridge.sim.sensors.offscreen import OffscreenRenderer
from simbridge.sim.sensors.rosmsg import Publication, header, new_message, point_cloud2

__all__ = ["CLOUD_DTYPE", "DepthCamera", "DepthCameraConfig", "depth_to_millimetres"]

CLOUD_DTYPE = np.dtype({"names": ["x", "y", "z"], "formats": ["<f4", "<f4", "<f4"]})

# Geometry nearer than range_min is still drawn down to this fraction of it, so that it
# reads -inf (REP 118 "too close") instead of vanishing through the near clip plane.
_NEAR_CLIP_FRACTION = 0.25


def depth_to_millimetres(depth: NDArray[np.float64]) -> NDArray[np.uint16]:
    """16UC1 depth: rounded millimetres, 0 for every non-finite or unrepresentable value."""
    valid = np.isfinite(depth) & (depth > 0) & (depth * 1000.0 < 65535.5)
    return np.where(valid, np.rint(np.where(valid, depth, 0.0) * 1000.0), 0).astype(np.uint16)


@dataclass(frozen=True, kw_only=True)
class DepthCameraConfig(SensorConfig):
    """A depth camera looking along the mount's +x. `fovy` is vertical, radians.

    Topics under `topic` (default `camera`): depth/image (32FC1, m), depth/image_raw (16UC1,
    mm), depth/points (organised PointCloud2) and depth/camera_info.
    """

    width: int = 320
    height: int = 240
    fovy: float = math.radians(60.0)
    range_min: float = 0.1
    range_max: float = 10.0


class DepthCamera(Sensor):
    """z-depth per pixel from the GL depth buffer, converted to metres."""

    def __init__(self, model: mujoco.MjModel, config: DepthCameraConfig) -> None:
        if not 0 < config.range_min < config.range_max:
            raise SimError(
                f"depth camera {config.name!r}: needs 0 < range_min < range_max, got "
                f"[{config.range_min}, {config.range_max}]"
            )
        self.config = config
        self.pinhole = PinholeModel(config.width, config.height, config.fovy)
        namespace = config.topic or "camera"
        self.depth_topic = f"{namespace}/depth/image"
        self.raw_topic = f"{namespace}/depth/image_raw"
        self.points_topic = f"{namespace}/depth/points"
        self.info_topic = f"{namespace}/depth/camera_info"
        super().__init__(
            config.name,
            config.mount().resolve(model),
            config.rate,
            frame_id=config.resolved_frame_id("_optical_frame"),
            outputs={
                self.depth_topic: "sensor_msgs/Image",
                self.raw_topic: "sensor_msgs/Image",
                self.points_topic: "sensor_msgs/PointCloud2",
                self.info_topic: "sensor_msgs/CameraInfo",
            },
            data_in_frame=Pose(np.zeros(3), OPTICAL_FROM_BODY),
        )
        self._renderer = LazyRenderer(
            lambda model: OffscreenRenderer(model, config.width, config.height)
        )

    def depth(self, model: mujoco.MjModel, data: mujoco.MjData) -> NDArray[np.float64]:
        """(height, width) z-depth in metres: +inf no return or beyond range_max,
        -inf closer than range_min (REP 118)."""
        cfg = self.config
        depth = self._renderer.get(model).render_depth(
            data,
            self.world_pose(data),
            cfg.fovy,
            cfg.range_min * _NEAR_CLIP_FRACTION,
            cfg.range_max * 2.0,
        )
        depth = np.where(depth > cfg.range_max, np.inf, depth)
        return np.where(depth < cfg.range_min, -np.inf, depth)

    def points(self, depth: NDArray[np.float64]) -> NDArray[np.float64]:
        """(height, width, 3) points in the optical frame; NaN where depth is not finite."""
        rays = self.pinhole.rays()
        z = np.where(np.isfinite(depth), depth, np.nan)
        return np.stack([rays[..., 0] * z, rays[..., 1] * z, z], axis=-1)

    def measure(self, model: mujoco.MjModel, data: mujoco.MjData) -> list[Publication]:
        """Render depth once if any image/cloud output is wanted; publish what is wanted."""
        now = float(data.time)
        cfg = self.config
        out: list[Publication] = []
        if (
            self.wanted(self.depth_topic)
            or self.wanted(self.raw_topic)
            or self.wanted(self.points_topic)
        ):
            depth = self.depth(model, data)
            if self.wanted(self.depth_topic):
                out.append(self._image(self.depth_topic, now, "32FC1", depth.astype(np.float32)))
            if self.wanted(self.raw_topic):
                out.append(self._image(self.raw_topic, now, "16UC1", depth_to_millimetres(depth)))
            if self.wanted(self.points_topic):
                xyz = self.points(depth)
                records = np.empty((cfg.height, cfg.width), dtype=CLOUD_DTYPE)
                records["x"], records["y"], records["z"] = xyz[..., 0], xyz[..., 1], xyz[..., 2]
                cloud = point_cloud2(
                    header(now, self.frame_id, self._next_seq(self.points_topic)),
                    records.reshape(-1),
                    height=cfg.height,
                    width=cfg.width,
                )
                out.append(self._publication(self.points_topic, cloud))
        if self.wanted(self.info_topic):
            info_header = header(now, self.frame_id, self._next_seq(self.info_topic))
            out.append(self._publication(self.info_topic, self.pinhole.camera_info(info_header)))
        return out

    def _image(
        self, topic: str, now: float, encoding: str, pixels: NDArray[np.generic]
    ) -> Publication:
        """A little-endian single-channel Image of `pixels` (float32 or uint16)."""
        little = np.ascontiguousarray(pixels, dtype=pixels.dtype.newbyteorder("<"))
        image = new_message(
            "sensor_msgs/Image",
            header=header(now, self.frame_id, self._next_seq(topic)),
            height=self.config.height,
            width=self.config.width,
            encoding=encoding,
            is_bigendian=0,
            step=little.dtype.itemsize * self.config.width,
            data=little.reshape(-1).view(np.uint8),
        )
        return self._publication(topic, image)

    def close(self) -> None:
        """Free the offscreen renderer."""
        self._renderer.close()
