"""The live detections for a known frame, in each generation's vision_msgs layout: noetic's
fields and values on ROS 1 (what a real rospy subscriber decodes), 4.x's on ROS 2, each
encodable by its registry; the sensor publisher's translator passes them as they are."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import pytest

from simbridge.errors import MessageError
from simbridge.messages import MessageRegistry, Translator, default_registry, ros2_registry
from simbridge.sim.labels.table import Instance, LabelTable
from simbridge.sim.sensors import LiveLabeller
from simbridge.sim.sensors.frames import Pose
from simbridge.sim.sensors.rosmsg import header

SCENE = """
<mujoco>
  <worldbody>
    <body name="crate" pos="0.5 -0.25 2"><geom type="box" size="0.1 0.1 0.1"/></body>
    <body name="ball" pos="0 0 3"><geom type="sphere" size="0.1"/></body>
  </worldbody>
</mujoco>
"""
GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)


def _frame(registry: MessageRegistry | None) -> Any:
    """The detections of one 8x6 frame: the crate (instance 1, class 2) covers columns 2-4
    of rows 1-2, the ball (instance 2, class 1) the single pixel (6, 5); the camera's
    optical frame is the world's, so poses are the bodies' world poses."""
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    crate, ball = (model.body(name).id for name in ("crate", "ball"))
    table = LabelTable(
        model,
        [
            Instance(1, "crate", "crate", 2, "object", (crate,), (0,)),
            Instance(2, "ball", "ball", 1, "object", (ball,), (1,)),
        ],
        ["ball", "crate"],
    )
    segments = np.zeros((6, 8), dtype=np.uint32)
    segments[1:3, 2:5] = 1
    segments[5, 6] = 2
    objects = np.array([[-1, -1], [0, GEOM], [1, GEOM]], dtype=np.int32)
    labeller = LiveLabeller("/cam", ["boxes_2d"])
    labeller.bind(table)
    if registry is not None:
        labeller.use_layouts(lambda: registry)
    ((topic, array),) = labeller.messages(
        ["/cam/detections"],
        segments,
        objects,
        data=data,
        optical=Pose(np.zeros(3), np.eye(3)),
        header=lambda topic: header(1.5, "cam_optical_frame", seq=7),
    )
    assert topic == "/cam/detections"
    return array


def _pose(result: Any) -> tuple[float, ...]:
    pose = result.pose.pose
    return (pose.position.x, pose.position.y, pose.position.z, pose.orientation.w)


def test_ros1_detections_have_noetics_fields_and_values() -> None:
    array = _frame(None)  # the default: noetic's layouts
    registry = default_registry()
    assert type(array) is registry.msg_class("vision_msgs/Detection2DArray")
    assert (array.header.seq, array.header.stamp.sec, array.header.stamp.nanosec) == (
        7,
        1,
        500_000_000,
    )
    crate, ball = array.detections
    assert [f.name for f in registry.schema("vision_msgs/Detection2D").fields] == [
        "header",
        "results",
        "bbox",
        "source_img",
    ]
    assert crate.header is array.header
    (hypothesis,) = crate.results
    assert (hypothesis.id, hypothesis.score) == (2, 1.0)  # the class id, as an int64
    assert _pose(hypothesis) == (0.5, -0.25, 2.0, 1.0)
    assert list(hypothesis.pose.covariance) == [0.0] * 36
    assert type(crate.bbox.center) is registry.msg_class("geometry_msgs/Pose2D")
    assert (crate.bbox.center.x, crate.bbox.center.y, crate.bbox.center.theta) == (3.0, 1.5, 0.0)
    assert (crate.bbox.size_x, crate.bbox.size_y) == (3.0, 2.0)
    assert (crate.source_img.height, crate.source_img.width, len(crate.source_img.data)) == (
        0,
        0,
        0,
    )
    assert (ball.results[0].id, ball.bbox.center.x, ball.bbox.center.y) == (1, 6.0, 5.0)
    assert (ball.bbox.size_x, ball.bbox.size_y) == (1.0, 1.0)
    assert _pose(ball.results[0]) == (0.0, 0.0, 3.0, 1.0)
    # The ROS 1 wire form decodes to the same values.
    decoded = registry.decode(registry.encode(array), "vision_msgs/Detection2DArray")
    assert registry.to_dict(decoded) == registry.to_dict(array)


def test_ros2_detections_have_4x_fields_and_values() -> None:
    registry = ros2_registry()
    array = _frame(registry)
    assert type(array) is registry.msg_class("vision_msgs/Detection2DArray")
    assert [f.name for f in registry.schema("std_msgs/Header").fields] == ["stamp", "frame_id"]
    assert (array.header.stamp.sec, array.header.frame_id) == (1, "cam_optical_frame")
    crate, ball = array.detections
    assert (crate.id, ball.id) == ("1", "2")  # instance ids
    hypothesis = crate.results[0].hypothesis
    assert (hypothesis.class_id, hypothesis.score) == ("crate", 1.0)
    assert ball.results[0].hypothesis.class_id == "ball"
    assert _pose(crate.results[0]) == (0.5, -0.25, 2.0, 1.0)
    centre = crate.bbox.center
    assert (centre.position.x, centre.position.y, centre.theta) == (3.0, 1.5, 0.0)
    assert (crate.bbox.size_x, crate.bbox.size_y) == (3.0, 2.0)
    decoded = registry.decode(registry.encode(array), "vision_msgs/Detection2DArray")
    assert registry.to_dict(decoded) == registry.to_dict(array)
    # Built for ROS 2, the sensor publisher's ROS 1 -> ROS 2 translator passes it as it is.
    assert Translator(default_registry(), registry).translate(array) is array


def test_translating_noetic_detections_to_4x_is_refused() -> None:
    """Why the builder fills each layout itself: the two differ beyond renames."""
    with pytest.raises(MessageError, match=r"BoundingBox2D\.center is geometry_msgs/Pose2D"):
        Translator(default_registry(), ros2_registry()).translate(_frame(None))
