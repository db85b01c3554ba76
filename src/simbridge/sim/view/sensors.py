"""Sensor readings in the view: lidar returns (2D scans and 3D point clouds) as points,
camera images in a panel.

The readings are the messages the simulation's own sensors publish (the same code the ROS
side runs): `SensorFeed.observe` is shown each batch of publications on the physics
thread, keeps only the newest scan and image (no queue), and the view's streaming thread
draws them at its bounded rate. `wants(topic)` tells the publisher to measure a topic
while a browser is watching it with its checkbox on, even if no ROS node subscribes.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
from numpy.typing import NDArray
from PIL import Image

from simbridge.sim.sensors import Camera, Lidar2D, Lidar3D, Publication, SensorSuite
from simbridge.sim.sensors.lidar3d import POINT_DTYPE

if TYPE_CHECKING:
    import viser

__all__ = ["LIDAR_RGB", "SensorFeed"]

LIDAR_RGB = (0, 200, 255)
"""Lidar returns are drawn cyan."""


def _decode(message: Any) -> NDArray[np.uint8]:
    """rgb8 pixels of a sensor_msgs/Image (rgb8) or CompressedImage (jpeg/png)."""
    if hasattr(message, "encoding"):
        flat = np.asarray(message.data, dtype=np.uint8)
        return flat.reshape(int(message.height), int(message.width), 3)
    data = bytes(np.asarray(message.data, dtype=np.uint8))
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"), dtype=np.uint8)


class SensorFeed:
    """The lidars' and cameras' latest readings of one `SensorSuite`, for the view."""

    def __init__(
        self, server: viser.ViserServer, suite: SensorSuite, point_size: float = 0.04
    ) -> None:
        self.server = server
        self.point_size = point_size
        self.lidars: dict[str, Lidar2D | Lidar3D] = {
            s.topic: s for s in suite.sensors if isinstance(s, Lidar2D | Lidar3D)
        }
        cameras = [s for s in suite.sensors if isinstance(s, Camera)]
        self.cameras = {c.compressed_topic: c for c in cameras} | {
            c.image_topic: c for c in cameras
        }
        self.points: dict[str, NDArray[np.float32]] = {}
        """Lidar topic -> the newest scan's returns in world coordinates (physics thread)."""
        self.images: dict[str, Any] = {}
        """Camera name -> the newest image message (decoded by the streaming thread)."""
        self.images_shown = 0
        """Camera images put in the panel (for tests and benchmarks)."""
        self._wanted: frozenset[str] = frozenset()
        self._drawn: dict[str, Any] = {}
        self._panels: dict[str, Any] = {}
        gui = server.gui
        self.lidar_box = gui.add_checkbox("Lidar points", initial_value=bool(self.lidars))
        self.camera_box = gui.add_checkbox("Camera images", initial_value=bool(cameras))
        self.lidar_box.visible, self.camera_box.visible = bool(self.lidars), bool(cameras)
        blank = np.zeros((1, 1, 3), dtype=np.uint8)
        for camera in cameras:
            self._panels[camera.name] = gui.add_image(blank, label=camera.name, format="jpeg")

    def wants(self, topic: str) -> bool:
        """Whether the view needs `topic` measured now: a browser is watching it with its
        checkbox on (the streaming thread works this out; here it is a set lookup, as the
        publisher asks every physics step)."""
        return topic in self._wanted

    def _update_wanted(self) -> None:
        wanted: set[str] = set()
        if self.server.get_clients():
            if self.lidar_box.value:
                wanted.update(self.lidars)
            if self.camera_box.value:
                wanted.update(c.compressed_topic for c in self.cameras.values())
        self._wanted = frozenset(wanted)

    def observe(self, publications: Sequence[Publication], data: mujoco.MjData) -> None:
        """Keep the newest scan (as world points) and image; physics thread, no waiting."""
        for publication in publications:
            lidar = self.lidars.get(publication.topic)
            if lidar is not None:
                self.points[publication.topic] = self._returns(lidar, publication.message, data)
                continue
            camera = self.cameras.get(publication.topic)
            if camera is not None:
                self.images[camera.name] = publication.message

    @staticmethod
    def _returns(
        lidar: Lidar2D | Lidar3D, message: Any, data: mujoco.MjData
    ) -> NDArray[np.float32]:
        """A LaserScan's or PointCloud2's returns in world coordinates."""
        if isinstance(lidar, Lidar3D):
            records = np.frombuffer(bytes(np.asarray(message.data, np.uint8)), POINT_DTYPE)
            local = np.stack([records["x"], records["y"], records["z"]], axis=1).astype(float)
        else:
            ranges = np.asarray(message.ranges, dtype=np.float64)
            hit = np.isfinite(ranges)
            angles = lidar.angles[hit]
            local = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
            local *= ranges[hit, None]
        pose = lidar.world_pose(data)  # the frame the scan was taken in: it is fresh now
        return (pose.position + local @ pose.rotation.T).astype(np.float32)

    def draw(self) -> None:
        """Send the newest readings (the streaming thread calls this)."""
        self._update_wanted()
        scene = self.server.scene
        show_points = bool(self.lidar_box.value)
        for topic, lidar in self.lidars.items():
            points = self.points.pop(topic, None)
            handle = self._drawn.get(topic)
            if not show_points:
                if handle is not None:
                    handle.remove()
                    del self._drawn[topic]
                continue
            if points is not None:
                self._drawn[topic] = scene.add_point_cloud(
                    f"/lidar/{lidar.name}",
                    points.reshape(-1, 3),
                    colors=LIDAR_RGB,
                    point_size=self.point_size,
                    point_shading="flat",
                    precision="float32",
                )
        for name, panel in self._panels.items():
            panel.visible = bool(self.camera_box.value)
            message = self.images.pop(name, None)
            if message is not None and panel.visible:
                panel.image = _decode(message)
                self.images_shown += 1

    def forget_scene(self) -> None:
        """The scene was cleared: the drawn point clouds are gone."""
        self._drawn.clear()
