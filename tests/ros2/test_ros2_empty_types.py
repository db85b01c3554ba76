"""Types with no fields between a Unity ROS 2 client, `simbridge endpoint --backend ros2` and
rclpy nodes in other processes (tests/ros2/ros2_node.py), both ways (issue 36).

Unity's ROS 2 serializer writes such a type as the CDR header alone, `00 01 00 00`; rclpy
refuses that (it wants rosidl's placeholder byte) and writes header, placeholder and
padding. The Unity frames here are spelled out by hand as its client writes them
(NUL-terminated names and JSON from JsonUtility, `pkg/Type` names), nothing built with
simbridge's encoder; rclpy decodes what it gets with its own classes. Then simbridge's
connector in ROS 2 mode (messages, services, an action whose feedback is empty), and the
endpoint's service clients leaving the graph with the client that made them.
"""

from __future__ import annotations

import struct
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from simbridge.connector import Connector, Ros2ActionClient
from simbridge.messages import ros2_registry
from simbridge.messages.actionlib import SUCCEEDED
from simbridge.protocol import (
    STATUS_SUCCEEDED,
    ActionFeedback,
    ActionGoal,
    ActionResult,
    ActionServerQuery,
    ActionServerReply,
    CommandReceived,
    ErrorMessage,
    MessageReceived,
    ServiceRequestReceived,
)
from tests.endpoint.rawclient import RawClient
from tests.ros2support import Ros2Process, require_ros2, start_endpoint, until_discovered

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(300)]

BARE = b"\x00\x01\x00\x00"
"""An empty type as Unity writes it (and what the endpoint hands every client)."""
PLACEHOLDER = b"\x00\x01\x00\x00\x00"
"""An empty type with rosidl's placeholder byte, as simbridge's connector wrote it."""
RCLPY_EMPTY = "0001000000000000"
"""What the endpoint hands ROS 2: header, placeholder, padding (as rclpy writes it)."""

REG = ros2_registry()


def frame(destination: bytes, payload: bytes) -> bytes:
    return (
        struct.pack("<I", len(destination))
        + destination
        + struct.pack("<I", len(payload))
        + payload
    )


def unity_command(name: str, body: str) -> bytes:
    """A system command as Unity's ROS 2 client writes it: name and JSON end in NUL."""
    return frame(name.encode() + b"\x00", body.encode() + b"\x00")


def registration(name: str, topic: str, msg_type: str) -> bytes:
    """`__subscribe`, `__ros_service` or `__unity_service` as Unity's client writes it."""
    return unity_command(name, f'{{"topic":"{topic}","message_name":"{msg_type}"}}')


def unity_message(topic: str, payload: bytes) -> bytes:
    return frame(topic.encode() + b"\x00", payload)


def trigger_response(success: bool, message: str) -> bytes:
    """std_srvs/Trigger response in CDR, by hand: bool, padding, string (NUL counted)."""
    text = message.encode() + b"\x00"
    return BARE + bytes([success]) + b"\x00\x00\x00" + struct.pack("<I", len(text)) + text


def decode_trigger_response(payload: bytes) -> tuple[bool, str]:
    (length,) = struct.unpack_from("<I", payload, 8)
    return bool(payload[4]), payload[12 : 12 + length - 1].decode()


def command(event: object, cls: type) -> bool:
    return isinstance(event, CommandReceived) and isinstance(event.command, cls)


def errors(client: RawClient) -> list[str]:
    """Texts of the `__error` frames received so far."""
    client.poll(0.2)
    return [
        e.command.text
        for e in client.events
        if isinstance(e, CommandReceived) and isinstance(e.command, ErrorMessage)
    ]


@pytest.fixture(scope="module")
def endpoint() -> Iterator[tuple[Ros2Process, int]]:
    require_ros2()
    proc, port = start_endpoint("--idle-timeout", "0")
    try:
        yield proc, port
    finally:
        proc.stop()


@pytest.fixture
def unity(endpoint: tuple[Ros2Process, int]) -> Iterator[RawClient]:
    raw = RawClient(endpoint[1])
    raw.send(b"\x00" * 8)  # Unity's first keepalive
    try:
        yield raw
    finally:
        raw.close()


@pytest.fixture(autouse=True)
def endpoint_log(endpoint: tuple[Ros2Process, int]) -> Iterator[None]:
    """What the endpoint logged during a test, printed after it (pytest shows it with a
    failure only)."""
    seen = len(endpoint[0].output)
    yield
    print("endpoint log:\n" + "".join(endpoint[0].output[seen:][-80:]))


def complaints(proc: Ros2Process, name: str) -> list[str]:
    """The endpoint's warnings and errors about topic or service `name`."""
    return [line for line in proc.output if name in line and ("WARNING" in line or "ERROR" in line)]


# ---- Unity -> ROS 2 -------------------------------------------------------------------


def test_unity_publishes_empty_messages_to_typed_and_raw_subscribers(
    endpoint: tuple[Ros2Process, int], unity: RawClient
) -> None:
    """Both spellings reach a typed rclpy subscription, and DDS carries rclpy's spelling.
    The publisher is latched (transient local), so both messages wait for the
    subscriptions however long their discovery takes."""
    topic = "/sb_empty_from_unity"
    with (
        Ros2Process.node("echo", topic, "std_msgs/msg/Empty", "2", "--latched") as typed,
        Ros2Process.node("echo", topic, "std_msgs/msg/Empty", "2", "--latched", "--raw") as raw,
    ):
        typed.expect_json("ready")
        raw.expect_json("ready")
        unity.send(
            unity_command(
                "__publish",
                f'{{"topic":"{topic}","message_name":"std_msgs/Empty","queue_size":10,'
                '"latch":true}',
            )
        )
        unity.send(unity_message(topic, BARE) + unity_message(topic, PLACEHOLDER))
        assert [typed.expect_json("msg", timeout=60) for _ in range(2)] == [{}, {}]
        assert [raw.expect_json("raw", timeout=60) for _ in range(2)] == [RCLPY_EMPTY] * 2
    assert errors(unity) == []
    assert complaints(endpoint[0], topic) == []


def test_unity_calls_a_ros2_trigger_service_with_either_spelling(unity: RawClient) -> None:
    service = "/sb_py_trigger"
    with Ros2Process.node(
        "serve", service, "std_srvs/srv/Trigger", '{"success": true, "message": "triggered"}'
    ) as server:
        server.expect_json("ready")
        unity.send(registration("__ros_service", service, "std_srvs/Trigger"))
        for first_id, request in ((5, BARE), (50, PLACEHOLDER)):

            def call(srv_id: int, request: bytes = request) -> bytes:
                return unity_command("__request", f'{{"srv_id":{srv_id}}}') + unity_message(
                    service, request
                )

            answer = unity.call_ros2_service(call, first_id)
            assert answer.service == service
            assert decode_trigger_response(answer.payload) == (True, "triggered")
            assert server.expect_json("request") == {}
    assert errors(unity) == []


def test_unity_calls_a_ros2_empty_service_and_gets_the_bare_header(unity: RawClient) -> None:
    service = "/sb_py_empty"
    with Ros2Process.node("serve", service, "std_srvs/srv/Empty", "{}") as server:
        server.expect_json("ready")
        unity.send(registration("__ros_service", service, "std_srvs/Empty"))
        answer = unity.call_ros2_service(
            lambda srv_id: (
                unity_command("__request", f'{{"srv_id":{srv_id}}}') + unity_message(service, BARE)
            ),
            8,
        )
        assert server.expect_json("request") == {}
    assert answer.payload == BARE


# ---- ROS 2 -> Unity -------------------------------------------------------------------


def test_ros2_publishes_empty_messages_to_unity(unity: RawClient) -> None:
    topic = "/sb_empty_to_unity"
    unity.send(registration("__subscribe", topic, "std_msgs/Empty"))
    with Ros2Process.node("pub", topic, "std_msgs/msg/Empty", "{}", "20", "3") as pub:
        got = [
            unity.expect(lambda e: isinstance(e, MessageReceived) and e.topic == topic, 30)
            for _ in range(3)
        ]
        assert pub.expect_json("sent") == 3
    assert [event.payload for event in got] == [BARE] * 3


def test_ros2_calls_a_unity_empty_service_answered_in_either_spelling(
    endpoint: tuple[Ros2Process, int], unity: RawClient
) -> None:
    service = "/sb_unity_empty"
    unity.send(registration("__unity_service", service, "std_srvs/Empty"))
    for answer in (BARE, PLACEHOLDER):
        with Ros2Process.node("call", service, "std_srvs/srv/Empty", "{}", "60") as caller:
            request = unity.expect(lambda e: isinstance(e, ServiceRequestReceived), timeout=60)
            assert (request.service, request.payload) == (service, BARE)
            unity.send(
                unity_command("__response", f'{{"srv_id":{request.srv_id}}}')
                + unity_message(service, answer)
            )
            assert caller.expect_json("response", timeout=30) == {}
    assert complaints(endpoint[0], service) == []


def test_ros2_calls_a_unity_trigger_service(unity: RawClient) -> None:
    service = "/sb_unity_trigger"
    unity.send(registration("__unity_service", service, "std_srvs/Trigger"))
    with Ros2Process.node("call", service, "std_srvs/srv/Trigger", "{}", "60") as caller:
        request = unity.expect(lambda e: isinstance(e, ServiceRequestReceived), timeout=60)
        assert request.payload == BARE
        unity.send(
            unity_command("__response", f'{{"srv_id":{request.srv_id}}}')
            + unity_message(service, trigger_response(True, "fired"))
        )
        assert caller.expect_json("response", timeout=30) == {"success": True, "message": "fired"}


# ---- the endpoint's service clients leave with their client ---------------------------


def endpoint_clients(prefix: str) -> list[str]:
    """Services the endpoint's node has clients of (seen from another node), under `prefix`."""
    with Ros2Process.node("clients", "simbridge_endpoint", "2") as probe:
        return [
            name for name in probe.expect_json("clients", timeout=60) if name.startswith(prefix)
        ]


def clients_until(
    prefix: str, predicate: Callable[[list[str]], bool], timeout: float = 90
) -> list[str]:
    """endpoint_clients until `predicate` holds (discovery of a change takes its time)."""
    deadline = time.monotonic() + timeout
    found = endpoint_clients(prefix)
    while not predicate(found) and time.monotonic() < deadline:
        found = endpoint_clients(prefix)
    return found


def test_service_clients_leave_the_graph_with_their_registration_and_client(
    endpoint: tuple[Ros2Process, int],
) -> None:
    prefix = "/sb_callers_"
    kept, removed = f"{prefix}kept", f"{prefix}removed"
    unity = RawClient(endpoint[1])
    try:
        for service in (kept, removed):
            unity.send(registration("__ros_service", service, "std_srvs/Trigger"))
        assert clients_until(prefix, lambda c: c == [kept, removed]) == [kept, removed]
        unity.send(unity_command("__remove_ros_service", f'{{"topic":"{removed}"}}'))
        assert clients_until(prefix, lambda c: c == [kept]) == [kept]
    finally:
        unity.close()
    assert clients_until(prefix, lambda c: c == []) == []


# ---- simbridge's connector in ROS 2 mode ----------------------------------------------


@pytest.fixture
def connector(endpoint: tuple[Ros2Process, int]) -> Iterator[Connector]:
    conn = Connector("127.0.0.1", endpoint[1]).connect()
    try:
        assert conn.protocol == "ROS2"
        yield conn
    finally:
        conn.close()


def test_connector_messages_and_services_of_empty_types(connector: Connector) -> None:
    topic_out, topic_in = "/sb_conn_empty_out", "/sb_conn_empty_in"
    with Ros2Process.node("echo", topic_out, "std_msgs/msg/Empty", "1", "--latched") as echo:
        echo.expect_json("ready")
        connector.register_publisher(topic_out, "std_msgs/Empty", latch=True)
        connector.publish(topic_out, REG.new("std_msgs/Empty"))
        assert echo.expect_json("msg", timeout=60) == {}

    received: list[Any] = []
    arrived = threading.Event()

    def on_empty(msg: Any) -> None:
        received.append(msg)
        arrived.set()

    connector.subscribe(topic_in, "std_msgs/Empty", on_empty)
    with Ros2Process.node("pub", topic_in, "std_msgs/msg/Empty", "{}", "20", "2"):
        assert arrived.wait(60)
    assert type(received[0]) is REG.msg_class("std_msgs/Empty")

    service = "/sb_conn_trigger"
    with Ros2Process.node(
        "serve", service, "std_srvs/srv/Trigger", '{"success": true, "message": "ok"}'
    ) as server:
        server.expect_json("ready")
        connector.register_ros_service(service, "std_srvs/Trigger")
        response = until_discovered(
            lambda: connector.call(service, REG.new("std_srvs/TriggerRequest"), timeout=30)
        )
        assert (response.success, response.message) == (True, "ok")
        assert server.expect_json("request") == {}

    served = "/sb_conn_empty_srv"
    requests: list[Any] = []

    def handle(request: Any) -> Any:
        requests.append(request)
        return REG.new("std_srvs/EmptyResponse")

    connector.implement_service(served, "std_srvs/Empty", handle)
    with Ros2Process.node("call", served, "std_srvs/srv/Empty", "{}", "60") as caller:
        assert caller.expect_json("response", timeout=60) == {}
    assert [type(r) for r in requests] == [REG.msg_class("std_srvs/EmptyRequest")]


# ---- an action whose feedback has no fields -------------------------------------------

LOOKUP = "tf2_msgs/LookupTransform"


def lookup_goal(target: str, source: str) -> Any:
    return REG.new("tf2_msgs/LookupTransformGoal", target_frame=target, source_frame=source)


def test_empty_action_feedback_reaches_raw_clients_and_the_connector(
    endpoint: tuple[Ros2Process, int], connector: Connector
) -> None:
    action = f"/sb_lookup_{time.monotonic_ns() % 10**9}"
    with Ros2Process.node("lookup", action) as server:
        server.expect_json("ready", timeout=60)
        raw = RawClient(endpoint[1])
        try:
            deadline = time.monotonic() + 60
            while True:
                raw.send(ActionServerQuery(action, LOOKUP).encode())
                reply = raw.expect(lambda e: command(e, ActionServerReply), timeout=20)
                if reply.command.ready or time.monotonic() > deadline:
                    break
                time.sleep(0.1)
            assert reply.command.ready
            goal = REG.encode(lookup_goal("map", "base"), fmt="cdr")
            raw.send(ActionGoal(1, action, LOOKUP, goal).encode())
            feedback = raw.expect(lambda e: command(e, ActionFeedback), timeout=30)
            result = raw.expect(lambda e: command(e, ActionResult), timeout=30)
            later = [
                e.command.feedback
                for e in raw.events
                if isinstance(e, CommandReceived) and isinstance(e.command, ActionFeedback)
            ]
        finally:
            raw.close()
        assert server.expect_json("goal") == "map"
        assert feedback.command.feedback == BARE
        assert later in ([], [BARE])
        assert result.command.status == STATUS_SUCCEEDED
        transform = REG.decode(result.command.result, "tf2_msgs/LookupTransformResult").transform
        assert (transform.header.frame_id, transform.child_frame_id) == ("map", "base")

        client = Ros2ActionClient(connector, action, LOOKUP)
        assert client.wait_for_server(60)
        feedbacks: list[Any] = []
        sent = client.send_goal(lookup_goal("odom", "tool"), on_feedback=feedbacks.append)
        assert sent.wait(60)
        assert sent.status == SUCCEEDED, sent.text
        assert sent.result.transform.child_frame_id == "tool"
        assert feedbacks
        assert all(type(f) is REG.msg_class("tf2_msgs/LookupTransformFeedback") for f in feedbacks)
        assert server.expect_json("goal") == "odom"
