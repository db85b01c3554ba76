"""Message objects <-> payloads in both protocol modes; raw payloads pass through."""

from __future__ import annotations

import dataclasses
import queue
from typing import Any

import pytest

from simbridge.connector.codec import PayloadCodec
from simbridge.errors import ConnectorError, MessageError
from simbridge.messages import default_registry
from simbridge.protocol import MessageReceived, ProtocolConnection
from tests.connector.conftest import FAST
from tests.connector.fake_endpoint import FakeEndpoint

REG = default_registry()


def twist() -> Any:
    msg = REG.new("geometry_msgs/Twist")
    msg.linear.x = 0.5
    msg.angular.z = -1.0
    return msg


def test_ros1_encoding_is_ros1_binary() -> None:
    codec = PayloadCodec(None, "ROS1")
    payload = codec.encode(twist(), "geometry_msgs/Twist")
    # six little-endian float64: 0.5, 0, 0, 0, 0, -1.0
    assert payload == (
        b"\x00\x00\x00\x00\x00\x00\xe0\x3f" + bytes(32) + b"\x00\x00\x00\x00\x00\x00\xf0\xbf"
    )
    assert codec.decode(payload, "geometry_msgs/Twist").angular.z == -1.0


def test_ros2_encoding_is_cdr_with_header() -> None:
    codec = PayloadCodec(REG, "ROS2")
    payload = codec.encode(twist(), "geometry_msgs/Twist")
    assert payload[:4] == b"\x00\x01\x00\x00"
    assert payload[4:12] == b"\x00\x00\x00\x00\x00\x00\xe0\x3f"
    assert codec.decode(payload, "geometry_msgs/Twist").linear.x == 0.5


def test_raw_payloads_pass_through() -> None:
    codec = PayloadCodec(REG, "ROS1")
    data = b"\x01\x02"
    assert codec.encode(data, "anything/AtAll") is data
    buf = bytearray(b"\x03")
    out = codec.encode(buf, "x/Y")
    buf[0] = 9
    assert out == b"\x03"  # copied: later changes to the bytearray do not leak


def test_wrong_object_type_names_both_types() -> None:
    codec = PayloadCodec(REG, "ROS1")
    with pytest.raises(ConnectorError, match=r"geometry_msgs/Pose.*geometry_msgs/Twist"):
        codec.encode(twist(), "geometry_msgs/Pose")


def test_malformed_payload_raises_message_error() -> None:
    with pytest.raises(MessageError):
        PayloadCodec(REG, "ROS1").decode(b"\x01", "geometry_msgs/Twist")


def test_service_parts() -> None:
    assert PayloadCodec(REG, "ROS1").service_parts("std_srvs/SetBool") == (
        "std_srvs/SetBoolRequest",
        "std_srvs/SetBoolResponse",
    )


def test_ros2_connector_sends_cdr_and_decodes_cdr(make_connector) -> None:
    with FakeEndpoint(keepalive=0.2, protocol="ROS2") as ep:
        conn = make_connector(ep.port, dataclasses.replace(FAST, protocol="ROS2")).connect()
        got: queue.Queue[Any] = queue.Queue()
        conn.subscribe("/in", "geometry_msgs/Twist", got.put)
        conn.register_publisher("/out", "geometry_msgs/Twist").publish(twist())
        cdr = REG.encode(twist(), "geometry_msgs/Twist", fmt="cdr")
        assert ep.wait_for(lambda: MessageReceived("/out", cdr) in ep.events())
        ep.send_all(ProtocolConnection.message("/in", cdr))
        assert got.get(timeout=3).angular.z == -1.0


def test_service_objects_through_the_fake(make_connector) -> None:
    def answer(_service: str, request: bytes) -> bytes:
        req = REG.decode(request, "std_srvs/SetBoolRequest")
        return REG.encode(REG.new("std_srvs/SetBoolResponse", success=req.data, message="ok"))

    with FakeEndpoint(keepalive=0.2, service_answer=answer) as ep:
        conn = make_connector(ep.port).connect()
        conn.register_ros_service("/set", "std_srvs/SetBool")
        response = conn.call("/set", REG.new("std_srvs/SetBoolRequest", data=True), timeout=3)
        assert (response.success, response.message) == (True, "ok")
        raw = conn.call_service(
            "/set", REG.new("std_srvs/SetBoolRequest", data=True), timeout=3, raw=True
        ).result(3)
        assert raw == REG.encode(REG.new("std_srvs/SetBoolResponse", success=True, message="ok"))
