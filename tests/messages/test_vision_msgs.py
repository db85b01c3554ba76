"""The shipped vision_msgs definitions match ROS's: noetic's (vision_msgs 0.0.2) for ROS 1,
so a real rospy or roscpp subscriber to a camera's detections accepts them (ROS 1 refuses a
connection whose md5sum differs), and vision_msgs 4.x (Jazzy) for ROS 2, from the package's
ros2/ folder (tests/endpoint/backends/ros2/test_build.py checks the built type hashes)."""

from __future__ import annotations

import pytest

from simbridge.messages import default_registry, ros2_registry

NOETIC_MD5 = {
    "vision_msgs/BoundingBox2D": "9ab41e2a4c8627735e5091a9abd68b02",
    "vision_msgs/Detection2D": "9e11092151fa150724a255fbac727f3b",
    "vision_msgs/Detection2DArray": "402071f61477de256df9f1aa45e6e4c8",
    "vision_msgs/ObjectHypothesis": "abf73443e563396425a38201e9dacc73",
    "vision_msgs/ObjectHypothesisWithPose": "fa1ab3bc7146f53921fa142d631d02db",
}
"""genmsg's md5sums (Debian's genmsg, gentools.compute_md5) of the files of the noetic-devel
branch of github.com/ros-perception/vision_msgs (release 0.0.2, commit 0c916da), with
std_msgs, geometry_msgs and sensor_msgs as Debian's noetic Python packages carry them
(their md5sums checked against the packages' own); simbridge's registry, loading those
files, computes the same."""


@pytest.mark.parametrize(("name", "md5"), sorted(NOETIC_MD5.items()))
def test_vision_msgs_checksums_are_noetics(name: str, md5: str) -> None:
    assert default_registry().md5(name) == md5


def _fields(protocol: str, name: str) -> list[tuple[str, str]]:
    registry = default_registry() if protocol == "ROS1" else ros2_registry()
    return [(f.name, f.type) for f in registry.schema(name).fields]


def test_ros1_layouts_are_noetics() -> None:
    assert _fields("ROS1", "vision_msgs/Detection2D") == [
        ("header", "std_msgs/Header"),
        ("results", "vision_msgs/ObjectHypothesisWithPose"),
        ("bbox", "vision_msgs/BoundingBox2D"),
        ("source_img", "sensor_msgs/Image"),
    ]
    assert _fields("ROS1", "vision_msgs/ObjectHypothesisWithPose") == [
        ("id", "int64"),
        ("score", "float64"),
        ("pose", "geometry_msgs/PoseWithCovariance"),
    ]
    assert _fields("ROS1", "vision_msgs/BoundingBox2D")[0] == ("center", "geometry_msgs/Pose2D")
    assert _fields("ROS1", "vision_msgs/ObjectHypothesis") == [
        ("id", "int64"),
        ("score", "float64"),
    ]
    # 4.x's own 2D point and pose do not exist in noetic.
    assert not default_registry().has("vision_msgs/Point2D")
    assert not default_registry().has("vision_msgs/Pose2D")


def test_ros2_layouts_are_4x() -> None:
    assert _fields("ROS2", "vision_msgs/Detection2D") == [
        ("header", "std_msgs/Header"),
        ("results", "vision_msgs/ObjectHypothesisWithPose"),
        ("bbox", "vision_msgs/BoundingBox2D"),
        ("id", "string"),
    ]
    assert _fields("ROS2", "vision_msgs/ObjectHypothesisWithPose") == [
        ("hypothesis", "vision_msgs/ObjectHypothesis"),
        ("pose", "geometry_msgs/PoseWithCovariance"),
    ]
    assert _fields("ROS2", "vision_msgs/ObjectHypothesis") == [
        ("class_id", "string"),
        ("score", "float64"),
    ]
    assert _fields("ROS2", "vision_msgs/BoundingBox2D")[0] == ("center", "vision_msgs/Pose2D")
    assert _fields("ROS2", "vision_msgs/Pose2D") == [
        ("position", "vision_msgs/Point2D"),
        ("theta", "float64"),
    ]
    assert _fields("ROS2", "vision_msgs/Point2D") == [("x", "float64"), ("y", "float64")]
