"""A session as a Unity ROS-TCP-Connector 0.7.0 client writes it, byte for byte.

The frames below are spelled out by hand (not built with simbridge's encoder), in the
order and JSON formatting Unity's JsonUtility produces, so the test pins the endpoint
to the real client rather than to simbridge's own idea of the protocol. The ROS 2 variant
replays the same client switched to ROS 2 (NUL-terminated strings, CDR payloads) against
the endpoint in ROS 2 mode.
"""

from __future__ import annotations

import struct
import threading
from collections.abc import Iterator

import pytest

from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.messages import default_registry, ros2_registry
from simbridge.protocol import (
    CommandReceived,
    ErrorMessage,
    Handshake,
    MessageReceived,
    ServiceRequestReceived,
    ServiceResponseReceived,
    TopicListReply,
)
from tests.endpoint.rawclient import RawClient


def frame(destination: bytes, payload: bytes) -> bytes:
    """uint32 LE name length, name, uint32 LE payload length, payload."""
    return (
        struct.pack("<I", len(destination))
        + destination
        + struct.pack("<I", len(payload))
        + payload
    )


KEEPALIVE = b"\x00\x00\x00\x00\x00\x00\x00\x00"  # empty name, empty payload
REGISTER_PUBLISHER = frame(
    b"__publish",
    b'{"topic":"/pos_rot","message_name":"geometry_msgs/Pose","queue_size":10,"latch":false}',
)
REGISTER_SUBSCRIBER = frame(
    b"__subscribe", b'{"topic":"/color","message_name":"std_msgs/ColorRGBA"}'
)
REGISTER_ROS_SERVICE = frame(
    b"__ros_service", b'{"topic":"/pos_srv","message_name":"std_srvs/Trigger"}'
)
POSE = struct.pack("<7d", 1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0)  # position xyz, orientation xyzw
TRIGGER_REQUEST = b""  # std_srvs/Trigger request has no fields


@pytest.fixture
def endpoint() -> Iterator[EndpointThread]:
    with EndpointThread(EndpointOptions(port=0)) as ep:
        yield ep


def test_unity_client_session(endpoint: EndpointThread) -> None:
    reg = default_registry()
    bus = endpoint.backend
    assert isinstance(bus, LocalBus)
    poses: list[object] = []
    with Node(bus, "/ros_side") as ros:
        ros.subscribe("/pos_rot", "geometry_msgs/Pose", poses.append)
        color = ros.advertise("/color", "std_msgs/ColorRGBA")
        ros.serve(
            "/pos_srv",
            "std_srvs/Trigger",
            lambda req: reg.new("std_srvs/TriggerResponse", success=True, message="ok"),
        )

        unity = RawClient(endpoint.port)
        unity.send(KEEPALIVE)  # Unity sends one right after connecting
        hello = unity.expect(lambda e: isinstance(e, CommandReceived)).command
        assert isinstance(hello, Handshake)
        assert hello.version.startswith("v0.7")
        assert hello.protocol == "ROS1"

        unity.send(REGISTER_PUBLISHER + REGISTER_SUBSCRIBER + REGISTER_ROS_SERVICE)
        unity.send(frame(b"__topic_list", b"{}"))
        listing = unity.expect(
            lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
        ).command
        assert dict(zip(listing.topics, listing.types, strict=True))["/pos_rot"] == (
            "geometry_msgs/Pose"
        )

        unity.send(frame(b"/pos_rot", POSE))
        color.publish(reg.new("std_msgs/ColorRGBA", r=1.0, a=1.0))
        got = unity.expect(lambda e: isinstance(e, MessageReceived))
        assert got.topic == "/color"
        assert struct.unpack("<4f", got.payload) == (1.0, 0.0, 0.0, 1.0)

        # A service call: header then request frame, back to back in one write.
        unity.send(frame(b"__request", b'{"srv_id":7}') + frame(b"/pos_srv", TRIGGER_REQUEST))
        answer = unity.expect(lambda e: isinstance(e, ServiceResponseReceived))
        assert answer.srv_id == 7
        assert answer.payload == b"\x01" + struct.pack("<I", 2) + b"ok"  # success, message

        # The 0.7.0 client sends __remove_* commands that the original endpoint cannot handle.
        unity.send(frame(b"__remove_subscriber", b'{"topic":"/color"}'))
        unity.send(frame(b"__topic_list", b"{}"))
        unity.expect(
            lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
        )
        assert not [
            e
            for e in unity.events
            if isinstance(e, CommandReceived) and isinstance(e.command, ErrorMessage)
        ]
        unity.close()
    assert len(poses) == 1
    pose = poses[0]
    assert (pose.position.x, pose.position.y, pose.position.z) == (1.0, 2.0, 3.0)  # type: ignore[attr-defined]


def test_ros2_mode_client_names_with_trailing_nul(endpoint: EndpointThread) -> None:
    """In ROS 2 mode Unity counts a trailing NUL in names and JSON; the endpoint strips it."""
    unity = RawClient(endpoint.port)
    unity.send(
        frame(b"__subscribe\x00", b'{"topic":"/odom","message_name":"nav_msgs/Odometry"}\x00')
    )
    unity.send(frame(b"__topic_list\x00", b"{}\x00"))
    listing = unity.expect(
        lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
    ).command
    assert "/odom" in listing.topics
    unity.close()


# ---- ROS 2 mode: the same client switched to ROS 2, against the endpoint in ROS 2 mode ----
# Unity's ROS 2 serializer writes every string, names and JSON alike, with a trailing NUL
# counted in its length, and message payloads as CDR with the little-endian encapsulation
# header 00 01 00 00.
CDR = b"\x00\x01\x00\x00"
R2_REGISTER_PUBLISHER = frame(
    b"__publish\x00",
    b'{"topic":"/pos_rot","message_name":"geometry_msgs/Pose","queue_size":10,"latch":false}\x00',
)
R2_REGISTER_SUBSCRIBER = frame(
    b"__subscribe\x00", b'{"topic":"/color","message_name":"std_msgs/ColorRGBA"}\x00'
)
R2_REGISTER_ROS_SERVICE = frame(
    b"__ros_service\x00", b'{"topic":"/enable","message_name":"std_srvs/SetBool"}\x00'
)
R2_REGISTER_UNITY_SERVICE = frame(
    b"__unity_service\x00", b'{"topic":"/unity_trigger","message_name":"std_srvs/SetBool"}\x00'
)
R2_POSE = CDR + POSE  # seven float64, 8-aligned after the header
R2_SETBOOL_TRUE = CDR + b"\x01"


@pytest.fixture
def ros2_endpoint() -> Iterator[EndpointThread]:
    with EndpointThread(EndpointOptions(port=0), LocalBus("ROS2")) as ep:
        yield ep


def test_unity_ros2_client_session(ros2_endpoint: EndpointThread) -> None:
    reg = ros2_registry()
    bus = ros2_endpoint.backend
    assert isinstance(bus, LocalBus)
    poses: list[object] = []
    with Node(bus, "/ros2_side") as ros:
        assert ros.registry is reg
        ros.subscribe("/pos_rot", "geometry_msgs/msg/Pose", poses.append)
        color = ros.advertise("/color", "std_msgs/msg/ColorRGBA")
        ros.serve(
            "/enable",
            "std_srvs/srv/SetBool",
            lambda req: reg.new("std_srvs/SetBoolResponse", success=req.data, message="ok"),
        )

        unity = RawClient(ros2_endpoint.port)
        unity.send(KEEPALIVE)
        hello = unity.expect(lambda e: isinstance(e, CommandReceived)).command
        assert isinstance(hello, Handshake)
        assert hello.protocol == "ROS2"  # a Unity client in ROS 2 mode refuses anything else

        unity.send(R2_REGISTER_PUBLISHER + R2_REGISTER_SUBSCRIBER + R2_REGISTER_ROS_SERVICE)
        unity.send(R2_REGISTER_UNITY_SERVICE)
        unity.send(frame(b"__topic_list\x00", b"{}\x00"))
        listing = unity.expect(
            lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
        ).command
        assert dict(zip(listing.topics, listing.types, strict=True))["/pos_rot"] == (
            "geometry_msgs/Pose"
        )

        unity.send(frame(b"/pos_rot\x00", R2_POSE))
        color.publish(reg.new("std_msgs/ColorRGBA", r=1.0, a=1.0))
        got = unity.expect(lambda e: isinstance(e, MessageReceived))
        assert got.topic == "/color"
        assert got.payload == CDR + struct.pack("<4f", 1.0, 0.0, 0.0, 1.0)

        # Unity calls a ROS 2 service: header then request frame, NUL-terminated names.
        unity.send(
            frame(b"__request\x00", b'{"srv_id":7}\x00') + frame(b"/enable\x00", R2_SETBOOL_TRUE)
        )
        answer = unity.expect(lambda e: isinstance(e, ServiceResponseReceived))
        assert answer.srv_id == 7
        # success, 3 bytes of padding, string length (NUL counted), "ok\0"
        assert answer.payload == CDR + b"\x01\x00\x00\x00" + struct.pack("<I", 3) + b"ok\x00"

        # A ROS 2 node calls the service Unity implements; Unity answers in CDR.
        results: list[object] = []
        caller = threading.Thread(
            target=lambda: results.append(
                ros.call(
                    "/unity_trigger",
                    "std_srvs/srv/SetBool",
                    reg.new("std_srvs/SetBoolRequest", data=True),
                    timeout=5,
                )
            )
        )
        caller.start()
        request = unity.expect(lambda e: isinstance(e, ServiceRequestReceived))
        assert request.service == "/unity_trigger"
        assert request.payload == R2_SETBOOL_TRUE
        reply = CDR + b"\x01\x00\x00\x00" + struct.pack("<I", 6) + b"fired\x00"
        header = b'{"srv_id":%d}\x00' % request.srv_id
        unity.send(frame(b"__response\x00", header) + frame(b"/unity_trigger\x00", reply))
        caller.join(5)
        assert len(results) == 1
        assert (results[0].success, results[0].message) == (True, "fired")  # type: ignore[attr-defined]

        unity.send(frame(b"__remove_subscriber\x00", b'{"topic":"/color"}\x00'))
        unity.send(frame(b"__topic_list\x00", b"{}\x00"))
        unity.expect(
            lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
        )
        assert not [
            e
            for e in unity.events
            if isinstance(e, CommandReceived) and isinstance(e.command, ErrorMessage)
        ]
        unity.close()
    assert len(poses) == 1
    pose = poses[0]
    assert type(pose) is reg.msg_class("geometry_msgs/Pose")
    assert (pose.position.x, pose.position.y, pose.position.z) == (1.0, 2.0, 3.0)  # type: ignore[attr-defined]
    assert pose.orientation.w == 1.0  # type: ignore[attr-defined]
