"""The simulator against a ROS 2 endpoint: the local bus in ROS 2 mode (CDR, ROS 2 layouts).

The same scene and sim code as in ROS 1 mode; the connector learns the protocol from the
handshake. Every topic is decoded with the ROS 2 (Jazzy) layouts by a bus node.
"""

from __future__ import annotations

import math
import queue
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from simbridge.apps.mobile_robot import SCENE_PATH
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.messages import ros2_registry
from simbridge.sim.runner import SimulationSession
from tests.waiting import wait_for

REG2 = ros2_registry()
TOPICS = {
    "/joint_states": "sensor_msgs/JointState",
    "/tf": "tf2_msgs/TFMessage",
    "/tf_static": "tf2_msgs/TFMessage",
    "/clock": "rosgraph_msgs/Clock",
    "/scan": "sensor_msgs/LaserScan",
    "/points": "sensor_msgs/PointCloud2",
    "/camera/image_raw": "sensor_msgs/Image",
    "/camera/image_raw/compressed": "sensor_msgs/CompressedImage",
    "/camera/camera_info": "sensor_msgs/CameraInfo",
    "/depth/depth/image": "sensor_msgs/Image",
    "/depth/depth/points": "sensor_msgs/PointCloud2",
    "/depth/depth/camera_info": "sensor_msgs/CameraInfo",
    "/imu": "sensor_msgs/Imu",
    "/odom": "nav_msgs/Odometry",
}


def _scene(tmp_path: Path) -> Path:
    """The mobile-robot room with every sensor kind, small enough to render quickly."""
    scene = yaml.safe_load(SCENE_PATH.read_text())
    scene["robots"][0]["urdf"] = str((SCENE_PATH.parent / scene["robots"][0]["urdf"]).resolve())
    scene["sensors"] = [
        {"type": "lidar_2d", "name": "laser", "body": "laser_link", "topic": "/scan",
         "rate": 10, "samples": 90, "range_max": 8.0,
         "ignore_bodies": ["base_link", "camera_link"]},
        {"type": "lidar_3d", "name": "velo", "body": "laser_link", "topic": "/points",
         "rate": 10, "channels": 4, "samples": 90},
        {"type": "camera", "name": "camera", "body": "camera_link", "topic": "/camera",
         "rate": 10, "width": 32, "height": 24},
        {"type": "depth_camera", "name": "depth", "body": "camera_link", "topic": "/depth",
         "rate": 10, "width": 32, "height": 24},
        {"type": "imu", "name": "imu", "body": "imu_link", "topic": "/imu", "rate": 50},
        {"type": "odometry", "name": "odom", "body": "base_link", "topic": "/odom", "rate": 50},
    ]  # fmt: skip
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene))
    return path


def _stamp(msg: Any) -> float:
    return float(msg.sec) + float(msg.nanosec) * 1e-9


@pytest.fixture
def ros2_endpoint() -> Any:
    with EndpointThread(EndpointOptions(port=0), LocalBus("ROS2")) as endpoint:
        yield endpoint


def test_every_topic_in_ros2_layouts_and_cmd_vel_drives(
    tmp_path: Path, ros2_endpoint: EndpointThread
) -> None:
    bus = ros2_endpoint.backend
    assert isinstance(bus, LocalBus)
    got: dict[str, queue.Queue[Any]] = {topic: queue.Queue() for topic in TOPICS}
    with Node(bus, "/ros2_tester") as node:
        assert node.registry is REG2
        for topic, msg_type in TOPICS.items():
            node.subscribe(topic, msg_type, got[topic].put)
        cmd_vel = node.advertise("/cmd_vel", "geometry_msgs/msg/Twist")
        address = f"127.0.0.1:{ros2_endpoint.port}"
        with SimulationSession(_scene(tmp_path), address, connect_timeout=60) as session:
            assert session.connector is not None
            assert session.connector.protocol == "ROS2"
            assert session.sensors is not None
            sensors = session.sensors
            lazy = [t for t in sensors.suite.outputs if t not in sensors.shared]
            publishers = [sensors.publisher(t) for t in lazy if t in TOPICS]  # subscribed
            deadline = time.monotonic() + 60
            while any(p.subscriber_count != 1 for p in publishers) and time.monotonic() < deadline:
                time.sleep(0.01)
            session.run(duration=0.3)
            twist = REG2.new("geometry_msgs/Twist", linear={"x": 0.4})
            for _ in range(5):
                cmd_vel.publish(twist)
                session.run(duration=0.2)
            assert session.connector.flush(60)
            messages = {topic: [got[topic].get(timeout=60)] for topic in TOPICS}

            def drain() -> bool:  # everything so far; true once the last /clock (1.3 s) came
                for topic, inbox in got.items():
                    while not inbox.empty():
                        messages[topic].append(inbox.get_nowait())
                return _stamp(messages["/clock"][-1].clock) >= 1.3 - 0.02

            assert wait_for(drain, timeout=60)
            time.sleep(0.2)  # anything after the last /clock (there should be nothing)
            drain()

    for topic, msg_type in TOPICS.items():
        first = messages[topic][0]
        assert type(first) is REG2.msg_class(msg_type), topic  # decoded with ROS 2 layouts
        header = getattr(first, "header", None)
        if header is not None:
            assert not hasattr(header, "seq"), topic
            assert header.frame_id or topic == "/joint_states", topic
            assert 0.0 < _stamp(header.stamp) <= 1.3 + 1e-9, topic

    for topic in ("/camera/camera_info", "/depth/depth/camera_info"):
        info = messages[topic][-1]
        fx, cx, fy, cy = info.k[0], info.k[2], info.k[4], info.k[5]
        assert (cx, cy) == (pytest.approx(15.5), pytest.approx(11.5))
        assert fx == pytest.approx(fy)
        assert fy == pytest.approx(12.0 / math.tan(1.047 / 2), rel=1e-3)  # default fovy
        assert info.p[0] == fx
        assert info.p[10] == 1.0
        assert info.r.tolist() == np.eye(3).ravel().tolist()
        assert info.d.tolist() == [0.0] * 5
        assert (info.width, info.height, info.distortion_model) == (32, 24, "plumb_bob")

    image = messages["/camera/image_raw"][-1]
    assert (image.width, image.height, image.encoding) == (32, 24, "rgb8")
    assert len(image.data) == 32 * 24 * 3
    assert messages["/camera/image_raw/compressed"][-1].data[:2].tobytes() == b"\xff\xd8"
    depth = messages["/depth/depth/image"][-1]
    assert depth.encoding == "32FC1"
    metres = np.frombuffer(depth.data.tobytes(), np.float32)
    finite = metres[np.isfinite(metres)]  # above the walls the camera sees nothing (inf)
    assert finite.size > 0
    assert finite.max() < 6.0  # inside the room

    clocks = [_stamp(m.clock) for m in messages["/clock"]]
    assert clocks == sorted(clocks)
    assert clocks[-1] == pytest.approx(1.3, abs=0.02)
    static_frames = {t.child_frame_id for m in messages["/tf_static"] for t in m.transforms}
    assert "camera_link_optical_frame" in static_frames  # a sensor frame, translated
    moving = {t.child_frame_id for m in messages["/tf"] for t in m.transforms}
    assert "left_wheel_link" in moving
    states = messages["/joint_states"][-1]
    assert "left_wheel_joint" in states.name
    assert len(states.position) == len(states.name)

    scan = messages["/scan"][-1]
    assert len(scan.ranges) == 90
    assert 0.0 < float(np.nanmin(scan.ranges)) < 2.5  # the walls are 2 m away
    odom = messages["/odom"][-1]
    assert odom.child_frame_id
    assert odom.pose.pose.position.x > 0.05  # /cmd_vel moved the robot forward
    imu = messages["/imu"][-1]
    assert imu.linear_acceleration.z == pytest.approx(9.81, abs=1.0)


def test_control_services_answer_in_ros2_layouts(
    tmp_path: Path, ros2_endpoint: EndpointThread
) -> None:
    bus = ros2_endpoint.backend
    assert isinstance(bus, LocalBus)
    scene = yaml.safe_load(SCENE_PATH.read_text())
    scene["robots"][0]["urdf"] = str((SCENE_PATH.parent / scene["robots"][0]["urdf"]).resolve())
    scene["sensors"] = []
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    address = f"127.0.0.1:{ros2_endpoint.port}"
    with (
        Node(bus, "/ros2_caller") as node,
        SimulationSession(tmp_path / "scene.yaml", address, connect_timeout=5) as session,
    ):
        assert session.connector is not None
        assert session.connector.flush(5)
        session.connector.endpoint_stats()  # a barrier: the services are advertised
        reply = node.call(
            "/simbridge/pause",
            "std_srvs/srv/SetBool",
            REG2.new("std_srvs/SetBoolRequest", data=True),
        )
        assert reply.success
        assert session.world.paused
