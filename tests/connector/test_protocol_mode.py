"""The connector's protocol mode: taken from the endpoint's handshake, or forced."""

from __future__ import annotations

import dataclasses
import queue
import struct
from typing import Any

import numpy as np

from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.messages import default_registry, ros2_registry
from simbridge.protocol import MessageReceived
from tests.connector.conftest import FAST
from tests.connector.fake_endpoint import FakeEndpoint
from tests.waiting import wait_for


def test_auto_mode_follows_a_ros2_handshake(make_connector) -> None:
    with FakeEndpoint(keepalive=0.2, protocol="ROS2") as ep:
        conn = make_connector(ep.port)
        assert conn.protocol == "ROS1"  # until the endpoint says otherwise
        pub = conn.register_publisher("/early", "std_msgs/Int32")
        pub.publish(default_registry().new("std_msgs/Int32", data=1))  # ROS 1 bytes, queued
        conn.connect()
        assert conn.protocol == "ROS2"
        assert conn.registry is ros2_registry()
        assert conn.stats().publish_drops == {"/early": 1}  # never sent in the wrong format
        pub.publish(conn.registry.new("std_msgs/Int32", data=2))
        cdr = b"\x00\x01\x00\x00" + struct.pack("<i", 2)
        assert ep.wait_for(lambda: MessageReceived("/early", cdr) in ep.events())
        assert not [
            e for e in ep.events() if isinstance(e, MessageReceived) and e.payload[:1] == b"\x01"
        ]


def test_auto_mode_keeps_ros1_for_a_ros1_endpoint(make_connector) -> None:
    with FakeEndpoint(keepalive=0.2) as ep:
        conn = make_connector(ep.port).connect()
        assert conn.protocol == "ROS1"
        assert conn.registry is default_registry()


def test_forced_mode_is_kept_against_a_mismatching_endpoint(make_connector) -> None:
    with FakeEndpoint(keepalive=0.2, protocol="ROS2") as ep:
        conn = make_connector(ep.port, dataclasses.replace(FAST, protocol="ROS1")).connect()
        assert conn.protocol == "ROS1"
        assert conn.registry is default_registry()


def test_ros2_layouts_between_a_connector_and_a_ros2_bus_node(make_connector) -> None:
    """CameraInfo (d k r p) and Header (no seq) cross the ROS 2 local bus as CDR."""
    with EndpointThread(EndpointOptions(port=0), LocalBus("ROS2")) as endpoint:
        bus = endpoint.backend
        assert isinstance(bus, LocalBus)
        sim = make_connector(endpoint.port).connect()
        reg = sim.registry
        assert reg.protocol == "ROS2"
        got: queue.Queue[Any] = queue.Queue()
        with Node(bus, "/ros2_side") as node:
            node.subscribe("/camera/camera_info", "sensor_msgs/msg/CameraInfo", got.put)
            poses = node.advertise("/pose", "geometry_msgs/PoseStamped")
            sim.subscribe("/pose", "geometry_msgs/PoseStamped", got.put)
            sim.endpoint_stats()  # a barrier: the subscription reached the bus
            info = sim.register_publisher("/camera/camera_info", "sensor_msgs/CameraInfo")
            sim.endpoint_stats()
            info.publish(
                reg.new(
                    "sensor_msgs/CameraInfo",
                    header={"stamp": {"sec": 5, "nanosec": 6}, "frame_id": "cam"},
                    k=np.arange(9.0),
                    d=[0.5],
                )
            )
            received = got.get(timeout=5)
            assert received.k.tolist() == list(range(9))
            assert received.d.tolist() == [0.5]
            assert (received.header.stamp.sec, received.header.frame_id) == (5, "cam")
            poses.publish(
                node.registry.new("geometry_msgs/PoseStamped", header={"frame_id": "map"})
            )
            pose = got.get(timeout=5)
            assert pose.header.frame_id == "map"
            assert not hasattr(pose.header, "seq")
        assert wait_for(lambda: sim.stats().frames_received > 0)
