"""`simbridge endpoint --backend ros2` against real rclpy nodes in other processes.

The endpoint runs as a subprocess with the ROS 2 venv's Python (rclpy cannot live
beside this process's rospy); the helper nodes are tests/ros2/ros2_node.py. CDR
payloads on the client side come from rosbags' Jazzy type store, so nothing here
shares code with the endpoint's relaying.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from tests.endpoint.rawclient import RawClient
from tests.ros2support import Ros2Process, require_ros2, start_endpoint

from simbridge.protocol import (
    CommandReceived,
    ErrorMessage,
    Handshake,
    MessageReceived,
    ProtocolConnection,
    Publish,
    RemovePublisher,
    RemoveSubscriber,
    RosService,
    ServiceRequestReceived,
    Subscribe,
    SubscriberCount,
    TopicListReply,
    TopicListRequest,
    UnityService,
)

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(240)]

TS = get_typestore(Stores.ROS2_JAZZY)
# Jazzy's store has no std_srvs: its request/response messages (CDR as rosidl lays them out).
for _name, _text in {
    "std_srvs/msg/SetBool_Request": "bool data",
    "std_srvs/msg/SetBool_Response": "bool success\nstring message",
    "std_srvs/msg/Trigger_Request": "uint8 structure_needs_at_least_one_member",
    "std_srvs/msg/Trigger_Response": "bool success\nstring message",
}.items():
    TS.register(get_types_from_msg(_text, _name))


def cdr(msg: object, ros2_type: str) -> bytes:
    return bytes(TS.serialize_cdr(msg, ros2_type))


def twist(x: float, yaw: float) -> bytes:
    v3 = TS.types["geometry_msgs/msg/Vector3"]
    tw = TS.types["geometry_msgs/msg/Twist"]
    return cdr(
        tw(linear=v3(x=x, y=0.0, z=0.0), angular=v3(x=0.0, y=0.0, z=yaw)), "geometry_msgs/msg/Twist"
    )


def command(event: object, cls: type) -> bool:
    return isinstance(event, CommandReceived) and isinstance(event.command, cls)


@pytest.fixture(scope="module")
def endpoint() -> Iterator[int]:
    require_ros2()
    proc, port = start_endpoint("--idle-timeout", "0")
    try:
        yield port
    finally:
        proc.stop()
        assert proc.proc.returncode is not None


@pytest.fixture
def client(endpoint: int) -> Iterator[RawClient]:
    raw = RawClient(endpoint)
    try:
        yield raw
    finally:
        raw.close()


def advertise(client: RawClient, topic: str, msg_type: str, **kw: object) -> None:
    """__publish, then wait until a ROS 2 subscription has matched (`__subscribers`)."""
    client.send(Publish(topic, msg_type, report_subscribers=True, **kw).encode())  # type: ignore[arg-type]
    client.expect(
        lambda e: command(e, SubscriberCount) and e.command.topic == topic and e.command.count >= 1,
        timeout=20,
    )


def test_handshake_says_ros2(endpoint: int) -> None:
    raw = RawClient(endpoint)
    try:
        event = raw.expect(lambda e: command(e, Handshake))
        assert event.command.metadata["protocol"] == "ROS2"
        assert "subscribers" in event.command.metadata["extensions"]
    finally:
        raw.close()


def test_twist_reaches_a_ros2_subscriber(client: RawClient) -> None:
    with Ros2Process.node("echo", "/sb_cmd_vel", "geometry_msgs/msg/Twist", "3") as echo:
        echo.expect_json("ready")
        advertise(client, "/sb_cmd_vel", "geometry_msgs/Twist")
        for i in range(3):
            client.send(ProtocolConnection.message("/sb_cmd_vel", twist(0.5 + i, -0.25)))
        got = [echo.expect_json("msg") for _ in range(3)]
    assert [m["linear"]["x"] for m in got] == [0.5, 1.5, 2.5]
    assert all(m["angular"]["z"] == -0.25 for m in got)


def test_image_reaches_a_ros2_subscriber(client: RawClient) -> None:
    pixels = (np.arange(480 * 640 * 3) % 251).astype(np.uint8)
    img_t, hdr_t = TS.types["sensor_msgs/msg/Image"], TS.types["std_msgs/msg/Header"]
    stamp = TS.types["builtin_interfaces/msg/Time"](sec=12, nanosec=34)
    image = img_t(
        header=hdr_t(stamp=stamp, frame_id="camera"),
        height=480,
        width=640,
        encoding="rgb8",
        is_bigendian=0,
        step=640 * 3,
        data=pixels,
    )
    with Ros2Process.node("echo", "/sb_image", "sensor_msgs/msg/Image", "1") as echo:
        echo.expect_json("ready")
        advertise(client, "/sb_image", "sensor_msgs/Image")
        client.send(ProtocolConnection.message("/sb_image", cdr(image, "sensor_msgs/msg/Image")))
        got = echo.expect_json("msg")
    assert (got["width"], got["height"], got["encoding"]) == (640, 480, "rgb8")
    assert got["header"] == {"stamp": {"sec": 12, "nanosec": 34}, "frame_id": "camera"}
    assert got["data"] == pixels.tolist()


def test_latched_topic_reaches_a_late_subscriber(client: RawClient) -> None:
    """Published before any subscriber exists (the stats reply is a barrier: the endpoint
    handed the message to rcl), kept by the transient-local publisher, and delivered to a
    subscriber that starts afterwards. Its start, its discovery of the publisher (reported
    by `__subscribers`) and the delivery are awaited one after the other, each with the
    deadline the other tests here give it."""
    client.send(
        Publish("/sb_latched", "std_msgs/String", latch=True, report_subscribers=True).encode()
    )
    string = TS.types["std_msgs/msg/String"]
    client.send(
        ProtocolConnection.message("/sb_latched", cdr(string(data="kept"), "std_msgs/msg/String"))
    )
    assert client.stats()["server"]["backend_counters"].get("publish_errors", 0) == 0
    with Ros2Process.node("echo", "/sb_latched", "std_msgs/msg/String", "1", "--latched") as echo:
        echo.expect_json("ready")
        client.wait_subscribers(1)
        assert echo.expect_json("msg") == {"data": "kept"}


def test_ros2_publisher_reaches_the_client(client: RawClient) -> None:
    client.send(Subscribe("/sb_chatter", "std_msgs/String").encode())
    with Ros2Process.node(
        "pub", "/sb_chatter", "std_msgs/msg/String", '{"data": "hello"}', "20", "60"
    ):
        event = client.expect(
            lambda e: isinstance(e, MessageReceived) and e.topic == "/sb_chatter", timeout=20
        )
    msg: Any = TS.deserialize_cdr(event.payload, "std_msgs/msg/String")
    assert msg.data == "hello"


def _received(client: RawClient, topics: list[str], count: int) -> dict[str, list[int]]:
    """The std_msgs/UInt32 values each topic brings, until every topic has `count`."""
    got: dict[str, list[int]] = {topic: [] for topic in topics}
    deadline = time.monotonic() + 60
    while any(len(v) < count for v in got.values()) and time.monotonic() < deadline:
        client.poll(0.2)
        for event in client.events:
            if isinstance(event, MessageReceived) and event.topic in got:
                msg: Any = TS.deserialize_cdr(bytes(event.payload), "std_msgs/msg/UInt32")
                got[event.topic].append(msg.data)
        client.events.clear()
    return got


def test_bursts_reach_the_client_whole_and_in_order(client: RawClient) -> None:
    """Two ROS 2 publishers' bursts at once arrive whole and in order (the event loop takes
    them, woken by the waiting thread); a subscription removed and made again still is."""
    count = 3000
    topics = ["/sb_burst_a", "/sb_burst_b"]
    for topic in topics:
        client.send(Subscribe(topic, "std_msgs/UInt32", queue_size=2 * count).encode())
    publishers = [Ros2Process.node("burst", topic, str(count)) for topic in topics]
    try:
        got = _received(client, topics, count)
        for publisher in publishers:
            assert publisher.expect_json("sent", timeout=60) == count
    finally:
        for publisher in publishers:
            publisher.stop()
    assert got == {topic: list(range(count)) for topic in topics}

    client.send(RemoveSubscriber(topics[0]).encode())
    time.sleep(0.5)
    client.send(Subscribe(topics[0], "std_msgs/UInt32", queue_size=2 * count).encode())
    with Ros2Process.node("burst", topics[0], str(count)) as publisher:
        again = _received(client, topics[:1], count)
        assert publisher.expect_json("sent", timeout=60) == count
    assert again == {topics[0]: list(range(count))}


def test_a_burst_to_a_client_that_stopped_reading_keeps_order(client: RawClient) -> None:
    """A burst taken while the client does not read: what the client can no longer take at
    once is queued up to its queue_size, dropping the oldest (counted); what arrives is in
    order, ends with the newest, and arrived + dropped is the whole burst. Covers a taken
    round handed over in part (the session's batch stops once the client pushes back)."""
    # a long name makes each frame ~170 bytes: the burst (~17 MB) outgrows the kernel's
    # socket buffers (4 MiB at most here) and the endpoint's 1 MiB write high-water mark
    topic, count, queue_size = "/sb_burst_stalled/" + "x" * 140, 100_000, 100
    client.send(Subscribe(topic, "std_msgs/UInt32", queue_size=queue_size).encode())
    with Ros2Process.node("burst", topic, str(count)) as publisher:
        assert publisher.expect_json("sent", timeout=90) == count  # all taken from DDS
    got: list[int] = []
    deadline = time.monotonic() + 60
    while (not got or got[-1] != count - 1) and time.monotonic() < deadline:
        client.poll(0.2)
        for event in client.events:
            if isinstance(event, MessageReceived) and event.topic == topic:
                got.append(int.from_bytes(event.payload[4:8], "little"))  # CDR UInt32
        client.events.clear()
    dropped = client.stats()["session"]["dropped"].get(topic, 0)
    assert got, "nothing arrived"
    assert got[-1] == count - 1
    assert all(a < b for a, b in itertools.pairwise(got)), "out of order"
    assert dropped > 0, "the client never fell behind: the test did not stall it"
    assert len(got) + dropped == count


def test_sim_calls_a_ros2_service(client: RawClient) -> None:
    with Ros2Process.node(
        "serve", "/sb_set", "std_srvs/srv/SetBool", '{"success": true, "message": "done"}'
    ) as server:
        server.expect_json("ready")
        client.send(RosService("/sb_set", "std_srvs/SetBool").encode())
        req_t = TS.types["std_srvs/msg/SetBool_Request"]
        request = cdr(req_t(data=True), "std_srvs/msg/SetBool_Request")
        event = client.call_ros2_service(
            lambda srv_id: ProtocolConnection.service_request(srv_id, "/sb_set", request), 7
        )
        assert server.expect_json("request") == {"data": True}
    response: Any = TS.deserialize_cdr(event.payload, "std_srvs/msg/SetBool_Response")
    assert (response.success, response.message) == (True, "done")


def test_a_call_nobody_answers_fails_fast(client: RawClient) -> None:
    client.send(RosService("/sb_nobody", "std_srvs/Trigger").encode())
    req_t = TS.types["std_srvs/msg/Trigger_Request"]
    client.send(
        ProtocolConnection.service_request(
            9,
            "/sb_nobody",
            cdr(req_t(structure_needs_at_least_one_member=0), "std_srvs/msg/Trigger_Request"),
        )
    )
    event = client.expect(lambda e: command(e, ErrorMessage), timeout=60)
    assert event.command.srv_id == 9
    assert "no ROS 2 server for '/sb_nobody'" in event.command.text


def test_ros2_client_calls_a_sim_service(client: RawClient) -> None:
    client.send(UnityService("/sb_reset", "std_srvs/Trigger").encode())
    time.sleep(0.3)
    with Ros2Process.node("call", "/sb_reset", "std_srvs/srv/Trigger", "{}", "20") as caller:
        request = client.expect(lambda e: isinstance(e, ServiceRequestReceived), timeout=20)
        assert request.service == "/sb_reset"
        resp_t = TS.types["std_srvs/msg/Trigger_Response"]
        client.send(
            ProtocolConnection.service_response(
                request.srv_id,
                "/sb_reset",
                cdr(resp_t(success=True, message="reset"), "std_srvs/msg/Trigger_Response"),
            )
        )
        assert caller.expect_json("response") == {"success": True, "message": "reset"}


def test_topic_list_in_unity_form(client: RawClient) -> None:
    client.send(Publish("/sb_listed", "geometry_msgs/Twist").encode())
    deadline = time.monotonic() + 10
    while True:
        client.send(TopicListRequest().encode())
        reply = client.expect(lambda e: command(e, TopicListReply)).command
        listed = dict(zip(reply.topics, reply.types, strict=True))
        if "/sb_listed" in listed or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    assert listed["/sb_listed"] == "geometry_msgs/Twist"
    assert listed["/rosout"] == "rcl_interfaces/Log"


def graph_topics() -> dict[str, list[str]]:
    with Ros2Process.node("graph", "3") as graph:
        return dict(graph.expect_json("topics"))


def graph_until(
    predicate: Callable[[dict[str, list[str]]], bool], timeout: float = 60
) -> dict[str, list[str]]:
    """graph_topics() until `predicate` holds of it or `timeout` s passed; the last one
    (DDS discovery of a change takes its time, more on a busy box)."""
    deadline = time.monotonic() + timeout
    topics = graph_topics()
    while not predicate(topics) and time.monotonic() < deadline:
        topics = graph_topics()
    return topics


def test_disconnect_and_remove_unregister(endpoint: int) -> None:
    first, second = RawClient(endpoint), RawClient(endpoint)
    try:
        first.send(Publish("/sb_gone", "std_msgs/String").encode())
        first.send(UnityService("/sb_gone_srv", "std_srvs/Trigger").encode())
        second.send(Publish("/sb_removed", "std_msgs/String").encode())
        before = graph_until(lambda t: "/sb_gone" in t and "/sb_removed" in t)
        assert "/sb_gone" in before
        assert "/sb_removed" in before
        first.close()
        second.send(RemovePublisher("/sb_removed").encode())
        after = graph_until(lambda t: "/sb_gone" not in t and "/sb_removed" not in t)
        assert "/sb_gone" not in after
        assert "/sb_removed" not in after
    finally:
        second.close()


def test_unknown_type_gets_an_error(client: RawClient) -> None:
    client.send(Publish("/sb_bad", "nosuch_msgs/Thing").encode())
    event = client.expect(lambda e: command(e, ErrorMessage), timeout=10)
    assert "nosuch_msgs/msg/Thing" in event.command.text
    assert "simbridge msg build" in event.command.text


def test_stats_include_backend_counters(client: RawClient) -> None:
    counters = client.stats()["server"]["backend_counters"]
    assert counters["publish_errors"] == 0


def test_tf_message_reaches_a_ros2_subscriber(client: RawClient) -> None:
    """tf2_msgs has no wheel: `make ros2` builds it from the shipped definitions."""
    tf_t = TS.types["tf2_msgs/msg/TFMessage"]
    ts_t = TS.types["geometry_msgs/msg/TransformStamped"]
    tr_t, v3, q = (
        TS.types[n]
        for n in (
            "geometry_msgs/msg/Transform",
            "geometry_msgs/msg/Vector3",
            "geometry_msgs/msg/Quaternion",
        )
    )
    hdr = TS.types["std_msgs/msg/Header"](
        stamp=TS.types["builtin_interfaces/msg/Time"](sec=5, nanosec=6), frame_id="world"
    )
    transform = ts_t(
        header=hdr,
        child_frame_id="base_link",
        transform=tr_t(translation=v3(x=1.0, y=2.0, z=3.0), rotation=q(x=0.0, y=0.0, z=0.0, w=1.0)),
    )
    with Ros2Process.node("echo", "/sb_tf", "tf2_msgs/msg/TFMessage", "1") as echo:
        echo.expect_json("ready")
        advertise(client, "/sb_tf", "tf2_msgs/TFMessage")
        client.send(
            ProtocolConnection.message(
                "/sb_tf", cdr(tf_t(transforms=[transform]), "tf2_msgs/msg/TFMessage")
            )
        )
        got = echo.expect_json("msg")
    (only,) = got["transforms"]
    assert only["child_frame_id"] == "base_link"
    assert only["header"]["frame_id"] == "world"
    assert only["transform"]["translation"] == {"x": 1.0, "y": 2.0, "z": 3.0}


def test_custom_type_reaches_a_ros2_subscriber(client: RawClient) -> None:
    """niryo_moveit (shipped, built by `make ros2`): a package of the user's kind."""
    TS.register(
        get_types_from_msg(
            "float64[6] joints\ngeometry_msgs/Pose pick_pose\ngeometry_msgs/Pose place_pose",
            "niryo_moveit/msg/NiryoMoveitJoints",
        )
    )
    joints_t = TS.types["niryo_moveit/msg/NiryoMoveitJoints"]
    pose_t, point_t, q = (
        TS.types[n]
        for n in (
            "geometry_msgs/msg/Pose",
            "geometry_msgs/msg/Point",
            "geometry_msgs/msg/Quaternion",
        )
    )
    pose = pose_t(position=point_t(x=0.1, y=0.2, z=0.3), orientation=q(x=0.0, y=0.0, z=0.0, w=1.0))
    msg = joints_t(joints=np.arange(6, dtype=np.float64) / 10, pick_pose=pose, place_pose=pose)
    with Ros2Process.node("echo", "/sb_joints", "niryo_moveit/msg/NiryoMoveitJoints", "1") as echo:
        echo.expect_json("ready")
        advertise(client, "/sb_joints", "niryo_moveit/NiryoMoveitJoints")
        client.send(
            ProtocolConnection.message("/sb_joints", cdr(msg, "niryo_moveit/msg/NiryoMoveitJoints"))
        )
        got = echo.expect_json("msg")
    assert got["joints"] == (np.arange(6, dtype=np.float64) / 10).tolist()
    assert got["pick_pose"]["position"] == {"x": 0.1, "y": 0.2, "z": 0.3}
