"""RGB camera: sensor_msgs/Image (rgb8), CompressedImage (jpeg/png) and CameraInfo, and
with `labelers:` live labels (instance and semantic segmentation, 2D detections)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import SimError, did_you_mean
from simbridge.sim.sensors.base import Sensor
from simbridge.sim.sensors.camera_model import OPTICAL_FROM_BODY, PinholeModel, optical_pose
from simbridge.sim.sensors.config import OptionError, SensorConfig
from simbridge.sim.sensors.encoding import (
    COMPRESSED_FORMATS,
    compressed_format_string,
    encode_rgb,
)
from simbridge.sim.sensors.frames import Pose
from simbridge.sim.sensors.labelled import LIVE_LABELERS, LabelLookup, LiveLabeller
from simbridge.sim.sensors.lazy_renderer import LazyRenderer
from simbridge.sim.sensors.offscreen import OffscreenRenderer
from simbridge.sim.sensors.rosmsg import Publication, header, new_message

__all__ = ["Camera", "CameraConfig"]


@dataclass(frozen=True, kw_only=True)
class CameraConfig(SensorConfig):
    """A colour camera looking along the mount's +x (z up). `fovy` is vertical, radians.

    Topics under `topic` (default `camera`): image_raw, image_raw/compressed, camera_info;
    with `labelers` (any of instance, semantic, boxes_2d) also instances and semantic
    (16UC1 ids) and detections (vision_msgs/Detection2DArray), ids as in a dataset of the
    scene. Default frame: `<body>_optical_frame` (REP 103: z forward, x right, y down).
    Shadows, reflections and MSAA (`multisamples`, e.g. 4) cost CPU time and are off.
    """

    width: int = 640
    height: int = 480
    fovy: float = math.radians(60.0)
    near: float = 0.01
    far: float = 100.0
    compression: str = "jpeg"
    jpeg_quality: int = 80
    shadows: bool = False
    reflections: bool = False
    multisamples: int = 0
    labelers: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for name in self.labelers:
            if name not in LIVE_LABELERS:
                raise OptionError(
                    type(self).__name__,
                    "labelers",
                    f"labelers: unknown labeler {name!r}{did_you_mean(name, LIVE_LABELERS)} "
                    f"(valid: {', '.join(LIVE_LABELERS)})",
                )
        if len(set(self.labelers)) != len(self.labelers):
            raise OptionError(
                type(self).__name__, "labelers", f"labelers: listed twice in {list(self.labelers)}"
            )


class Camera(Sensor):
    """Renders the scene offscreen; only the wanted outputs are rendered and encoded."""

    def __init__(self, model: mujoco.MjModel, config: CameraConfig) -> None:
        if config.compression not in COMPRESSED_FORMATS:
            raise SimError(
                f"camera {config.name!r}: compression {config.compression!r} is not one of "
                f"{COMPRESSED_FORMATS}"
            )
        if not 0 < config.near < config.far:
            raise SimError(
                f"camera {config.name!r}: needs 0 < near < far, got [{config.near}, {config.far}]"
            )
        self.config = config
        self.pinhole = PinholeModel(config.width, config.height, config.fovy)
        namespace = config.topic or "camera"
        self.image_topic = f"{namespace}/image_raw"
        self.compressed_topic = f"{namespace}/image_raw/compressed"
        self.info_topic = f"{namespace}/camera_info"
        self.labeller = LiveLabeller(namespace, config.labelers)
        """The label outputs (none without `labelers`); `bind_labels` gives them their ids."""
        super().__init__(
            config.name,
            config.mount().resolve(model),
            config.rate,
            frame_id=config.resolved_frame_id("_optical_frame"),
            outputs={
                self.image_topic: "sensor_msgs/Image",
                self.compressed_topic: "sensor_msgs/CompressedImage",
                self.info_topic: "sensor_msgs/CameraInfo",
                **self.labeller.outputs,
            },
            data_in_frame=Pose(np.zeros(3), OPTICAL_FROM_BODY),
        )
        self._renderer = LazyRenderer(
            lambda model: OffscreenRenderer(
                model,
                config.width,
                config.height,
                shadows=config.shadows,
                reflections=config.reflections,
                multisamples=config.multisamples,
            )
        )

    def bind_labels(self, lookup: LabelLookup) -> None:
        """Take instance and class ids from a scene's label table (needed by `labelers`)."""
        self.labeller.bind(lookup)

    def segmentation(
        self, model: mujoco.MjModel, data: mujoco.MjData
    ) -> tuple[NDArray[np.uint32], NDArray[np.int32]]:
        """The current view's segments: an image of segment numbers and each segment's
        MuJoCo object id and type (`OffscreenRenderer.render_segments`; the image's
        renderer serves: MuJoCo draws segmentation without multisampling)."""
        return self._renderer.get(model).render_segments(
            data, self.world_pose(data), self.config.fovy, self.config.near, self.config.far
        )

    def render(self, model: mujoco.MjModel, data: mujoco.MjData) -> NDArray[np.uint8]:
        """The current view as an (height, width, 3) rgb8 array."""
        return self._renderer.get(model).render_rgb(
            data, self.world_pose(data), self.config.fovy, self.config.near, self.config.far
        )

    def measure(self, model: mujoco.MjModel, data: mujoco.MjData) -> list[Publication]:
        """Render once if any image output is wanted; publish the wanted outputs."""
        now = float(data.time)
        out: list[Publication] = []
        if self.wanted(self.image_topic) or self.wanted(self.compressed_topic):
            rgb = self.render(model, data)
            if self.wanted(self.image_topic):
                image = new_message(
                    "sensor_msgs/Image",
                    header=header(now, self.frame_id, self._next_seq(self.image_topic)),
                    height=self.config.height,
                    width=self.config.width,
                    encoding="rgb8",
                    is_bigendian=0,
                    step=3 * self.config.width,
                    data=rgb.reshape(-1),
                )
                out.append(self._publication(self.image_topic, image))
            if self.wanted(self.compressed_topic):
                fmt = self.config.compression
                compressed = new_message(
                    "sensor_msgs/CompressedImage",
                    header=header(now, self.frame_id, self._next_seq(self.compressed_topic)),
                    format=compressed_format_string(fmt),
                    data=np.frombuffer(
                        encode_rgb(rgb, fmt, self.config.jpeg_quality), dtype=np.uint8
                    ),
                )
                out.append(self._publication(self.compressed_topic, compressed))
        if self.wanted(self.info_topic):
            info_header = header(now, self.frame_id, self._next_seq(self.info_topic))
            out.append(self._publication(self.info_topic, self.pinhole.camera_info(info_header)))
        labels = [topic for topic in self.labeller.outputs if self.wanted(topic)]
        if labels:
            if not self.labeller.bound:
                raise SimError(
                    f"camera {self.name!r} has labelers {list(self.config.labelers)} but no "
                    "scene labels were bound (Camera.bind_labels with the scene's LabelTable)"
                )
            segments, objects = self.segmentation(model, data)
            messages = self.labeller.messages(
                labels,
                segments,
                objects,
                data=data,
                optical=optical_pose(self.world_pose(data)),
                header=lambda topic: header(now, self.frame_id, self._next_seq(topic)),
            )
            out += [self._publication(topic, message) for topic, message in messages]
        return out

    def close(self) -> None:
        """Free the offscreen renderer."""
        self._renderer.close()
