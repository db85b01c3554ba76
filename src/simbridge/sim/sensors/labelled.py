"""Live labels of a camera: instance and semantic segmentation images and 2D detections
(`vision_msgs/Detection2DArray`) of what the camera sees, each frame, next to its image.

The ids come from a `LabelLookup` (a scene's `simbridge.sim.labels.LabelTable`, bound by
whoever knows the scene: the ROS layer), the same ids a dataset of the scene carries.
Detections take the layouts of the registry they will go out through: noetic's vision_msgs on
ROS 1 (class id as int64, a geometry_msgs/Pose2D box centre, no instance id), vision_msgs
4.x on ROS 2 (class name, vision_msgs/Pose2D centre, the instance id as the tracking id).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import mujoco
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from simbridge.messages import MessageRegistry, Translator, default_registry
from simbridge.sim.sensors.frames import Pose
from simbridge.sim.sensors.rosmsg import new_message, pose_message

__all__ = [
    "LIVE_LABELERS",
    "Detection",
    "LabelLookup",
    "LabelledInstance",
    "LiveLabeller",
    "detections",
]

LIVE_LABELERS = ("instance", "semantic", "boxes_2d")
"""What a camera's `labelers:` may list: instance ids and class ids per pixel
(`<topic>/instances`, `<topic>/semantic`, 16UC1) and tight 2D boxes (`<topic>/detections`)."""

_SUFFIXES = {"instance": "instances", "semantic": "semantic", "boxes_2d": "detections"}
_TYPES = {
    "instance": "sensor_msgs/Image",
    "semantic": "sensor_msgs/Image",
    "boxes_2d": "vision_msgs/Detection2DArray",
}


class LabelledInstance(Protocol):
    """One labelled thing (`simbridge.sim.labels.Instance` fits)."""

    @property
    def id(self) -> int: ...

    @property
    def category(self) -> str: ...

    @property
    def category_id(self) -> int: ...

    @property
    def root_body(self) -> int: ...


class LabelLookup(Protocol):
    """Instances and per-pixel ids of a scene (`simbridge.sim.labels.LabelTable` fits)."""

    @property
    def instances(self) -> Sequence[LabelledInstance]: ...

    def instance_image(self, segmentation: NDArray[np.int32]) -> NDArray[np.uint16]: ...

    def category_image(self, segmentation: NDArray[np.int32]) -> NDArray[np.uint16]: ...


@dataclass(frozen=True)
class Detection:
    """An instance seen in one image: its tight box and its pose in the optical frame."""

    instance: LabelledInstance
    box: tuple[int, int, int, int]
    """(column_min, row_min, column_max, row_max) of its visible pixels, inclusive."""
    pose: Pose
    """Its root body's pose in the camera's optical frame (REP 103: z forward)."""

    @property
    def center(self) -> tuple[float, float]:
        """Box centre in pixel coordinates (pixel centres at integers, as in CameraInfo)."""
        u0, v0, u1, v1 = self.box
        return ((u0 + u1) / 2.0, (v0 + v1) / 2.0)

    @property
    def size(self) -> tuple[float, float]:
        """Box width and height in pixels (whole pixels: edges at the outer pixel borders)."""
        u0, v0, u1, v1 = self.box
        return (float(u1 - u0 + 1), float(v1 - v0 + 1))


def detections(
    lookup: LabelLookup, instance_image: NDArray[np.uint16], data: mujoco.MjData, optical: Pose
) -> list[Detection]:
    """Every instance with visible pixels in `instance_image`, in id order."""
    found = ndimage.find_objects(instance_image)
    out = []
    rotation_t = optical.rotation.T
    for instance in lookup.instances:
        where = found[instance.id - 1] if instance.id - 1 < len(found) else None
        if where is None:
            continue
        rows, cols = where
        body = instance.root_body
        pose = Pose(
            rotation_t @ (data.xpos[body] - optical.position),
            rotation_t @ data.xmat[body].reshape(3, 3),
        )
        box = (cols.start, rows.start, cols.stop - 1, rows.stop - 1)
        out.append(Detection(instance, box, pose))
    return out


class LiveLabeller:
    """A camera's label outputs under its topic namespace, and their messages per frame."""

    def __init__(self, namespace: str, labelers: Sequence[str]) -> None:
        self.topics = {name: f"{namespace}/{_SUFFIXES[name]}" for name in labelers}
        """Labeler -> topic, for the labelers asked for."""
        self._lookup: LabelLookup | None = None
        self._layouts: Callable[[], MessageRegistry] = default_registry
        self._translator: Translator | None = None

    @property
    def outputs(self) -> dict[str, str]:
        """Topic -> ROS 1 message type of each label output."""
        return {topic: _TYPES[name] for name, topic in self.topics.items()}

    @property
    def bound(self) -> bool:
        """Whether a scene's labels were bound (without them nothing can be labelled)."""
        return self._lookup is not None

    def bind(self, lookup: LabelLookup) -> None:
        """Take ids and classes from `lookup` (a scene's label table)."""
        self._lookup = lookup

    def use_layouts(self, registry: Callable[[], MessageRegistry]) -> None:
        """Build detections in the layouts of `registry()`, asked each frame (a connector's
        turns ROS 2 when a ROS 2 endpoint's handshake arrives); noetic's until then."""
        self._layouts = registry

    def messages(
        self,
        wanted: Sequence[str],
        segments: NDArray[np.uint32],
        objects: NDArray[np.int32],
        *,
        data: mujoco.MjData,
        optical: Pose,
        header: Any,
    ) -> list[tuple[str, Any]]:
        """(topic, message) of each wanted label topic for one segmentation (an image of
        segment numbers and each segment's object id and type); `header` is called with
        a topic and gives its stamped header."""
        lookup = self._lookup
        assert lookup is not None, "LiveLabeller.bind first"
        height, width = segments.shape
        out: list[tuple[str, Any]] = []
        # Ids per segment (a few dozen), then one look-up per pixel.
        instances = lookup.instance_image(objects)[segments]
        for name in ("instance", "semantic"):
            topic = self.topics.get(name)
            if topic is None or topic not in wanted:
                continue
            ids = instances if name == "instance" else lookup.category_image(objects)[segments]
            out.append((topic, _image(header(topic), ids, width, height)))
        topic = self.topics.get("boxes_2d")
        if topic is not None and topic in wanted:
            found = detections(lookup, instances, data, optical)
            registry = self._layouts()
            stamped = self._header_for(registry, header(topic))
            out.append((topic, _detection_array(registry, stamped, found)))
        return out

    def _header_for(self, registry: MessageRegistry, header: Any) -> Any:
        """`header` (a noetic std_msgs/Header, as sensors build it) in `registry`'s layout."""
        if registry is default_registry():
            return header
        if self._translator is None or self._translator.dst is not registry:
            self._translator = Translator(default_registry(), registry)
        return self._translator.translate(header)


def _image(header: Any, ids: NDArray[np.uint16], width: int, height: int) -> Any:
    """A 16UC1 little-endian Image of ids."""
    little = np.ascontiguousarray(ids, dtype="<u2")
    return new_message(
        "sensor_msgs/Image",
        header=header,
        height=height,
        width=width,
        encoding="16UC1",
        is_bigendian=0,
        step=2 * width,
        data=little.reshape(-1).view(np.uint8),
    )


def _detection_array(registry: MessageRegistry, header: Any, found: Sequence[Detection]) -> Any:
    """vision_msgs/Detection2DArray in `registry`'s layout: per instance its box, class
    (score 1) and pose; on vision_msgs 4.x also its instance id."""
    cls = registry.msg_class
    fields = registry.schema("vision_msgs/ObjectHypothesisWithPose").fields
    vision_4x = any(field.name == "hypothesis" for field in fields)
    empty_image = None if vision_4x else registry.new("sensor_msgs/Image")
    items = []
    for detection in found:
        u, v = detection.center
        size_x, size_y = detection.size
        instance = detection.instance
        pose = cls("geometry_msgs/PoseWithCovariance")(
            pose=pose_message(detection.pose), covariance=np.zeros(36)
        )
        extra: dict[str, Any]
        if vision_4x:
            centre = cls("vision_msgs/Pose2D")(
                position=cls("vision_msgs/Point2D")(x=u, y=v), theta=0.0
            )
            hypothesis = cls("vision_msgs/ObjectHypothesisWithPose")(
                hypothesis=cls("vision_msgs/ObjectHypothesis")(
                    class_id=instance.category, score=1.0
                ),
                pose=pose,
            )
            extra = {"id": str(instance.id)}
        else:
            centre = cls("geometry_msgs/Pose2D")(x=u, y=v, theta=0.0)
            hypothesis = cls("vision_msgs/ObjectHypothesisWithPose")(
                id=instance.category_id, score=1.0, pose=pose
            )
            extra = {"source_img": empty_image}
        box = cls("vision_msgs/BoundingBox2D")(center=centre, size_x=size_x, size_y=size_y)
        items.append(
            cls("vision_msgs/Detection2D")(header=header, results=[hypothesis], bbox=box, **extra)
        )
    return cls("vision_msgs/Detection2DArray")(header=header, detections=items)
