"""A Unity client in ROS 2 mode and types with no fields, against the embedded bus (no ROS 2
install): its header-only CDR (`00 01 00 00`) decodes in in-process nodes, which answer in
ROS 2's spelling; and the callers its `__ros_service` registrations get from the backend
are closed with the registration or the connection (issue 36). The same against rclpy is
tests/ros2/test_ros2_empty_types.py."""

from __future__ import annotations

import struct
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.endpoint.backends.base import BackendServiceClient
from simbridge.messages import ros2_registry
from simbridge.protocol import (
    CommandReceived,
    ErrorMessage,
    ServiceRequestReceived,
    ServiceResponseReceived,
)
from tests.endpoint.rawclient import RawClient

HEADER_ONLY = b"\x00\x01\x00\x00"
ROS2_SPELLING = b"\x00\x01\x00\x00\x00\x00\x00\x00"
REG = ros2_registry()


def frame(destination: bytes, payload: bytes) -> bytes:
    head = struct.pack("<I", len(destination)) + destination
    return head + struct.pack("<I", len(payload)) + payload


def unity_command(name: str, body: str) -> bytes:
    """As Unity's ROS 2 client writes it: name and JSON end in NUL."""
    return frame(name.encode() + b"\x00", body.encode() + b"\x00")


def registration(name: str, topic: str, msg_type: str) -> bytes:
    return unity_command(name, f'{{"topic":"{topic}","message_name":"{msg_type}"}}')


def no_errors(client: RawClient) -> bool:
    return not [
        e
        for e in client.events
        if isinstance(e, CommandReceived) and isinstance(e.command, ErrorMessage)
    ]


class _Watched(BackendServiceClient):
    """A caller whose close() is seen by the test."""

    def __init__(self, inner: BackendServiceClient, service: str) -> None:
        self.inner = inner
        self.service = service
        self.closed = False

    async def call(self, request: bytes, *, timeout: float) -> bytes:
        return await self.inner.call(request, timeout=timeout)

    def close(self) -> None:
        self.closed = True
        self.inner.close()


class WatchedBus(LocalBus):
    """The embedded bus in ROS 2 mode, keeping every caller it handed out."""

    def __init__(self) -> None:
        super().__init__("ROS2")
        self.callers: list[_Watched] = []

    def service_client(self, service: str, srv_type: str) -> BackendServiceClient:
        caller = _Watched(super().service_client(service, srv_type), service)
        self.callers.append(caller)
        return caller

    def open_callers(self) -> list[str]:
        return sorted(c.service for c in list(self.callers) if not c.closed)


def wait_until(predicate: Callable[[], bool], timeout: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


@pytest.fixture
def endpoint() -> Iterator[EndpointThread]:
    with EndpointThread(EndpointOptions(port=0), WatchedBus()) as ep:
        yield ep


def test_header_only_payloads_reach_in_process_nodes(endpoint: EndpointThread) -> None:
    bus = endpoint.backend
    assert isinstance(bus, WatchedBus)
    pings: list[Any] = []
    with Node(bus, "/ros2_side") as ros:
        ros.subscribe("/ping", "std_msgs/msg/Empty", pings.append)
        ros.serve(
            "/trigger",
            "std_srvs/srv/Trigger",
            lambda _req: REG.new("std_srvs/TriggerResponse", success=True, message="ok"),
        )
        unity = RawClient(endpoint.port)
        unity.send(b"\x00" * 8)
        unity.send(
            unity_command(
                "__publish",
                '{"topic":"/ping","message_name":"std_msgs/Empty","queue_size":10,"latch":false}',
            )
        )
        unity.send(registration("__ros_service", "/trigger", "std_srvs/Trigger"))
        unity.send(registration("__unity_service", "/reset", "std_srvs/Empty"))
        unity.send(frame(b"/ping\x00", HEADER_ONLY))
        unity.send(unity_command("__request", '{"srv_id":3}') + frame(b"/trigger\x00", HEADER_ONLY))
        answer = unity.expect(lambda e: isinstance(e, ServiceResponseReceived))
        assert answer.srv_id == 3
        assert answer.payload == HEADER_ONLY + b"\x01\x00\x00\x00\x03\x00\x00\x00ok\x00"

        results: list[Any] = []
        caller = threading.Thread(
            target=lambda: results.append(
                ros.call("/reset", "std_srvs/srv/Empty", REG.new("std_srvs/EmptyRequest"))
            )
        )
        caller.start()
        request = unity.expect(lambda e: isinstance(e, ServiceRequestReceived))
        assert request.payload == ROS2_SPELLING  # what an in-process node writes
        unity.send(
            unity_command("__response", f'{{"srv_id":{request.srv_id}}}')
            + frame(b"/reset\x00", HEADER_ONLY)
        )
        caller.join(10)
        unity.stats()  # a barrier: every frame above was handled
        assert no_errors(unity)
        unity.close()
    assert results == [REG.new("std_srvs/EmptyResponse")]
    assert pings == [REG.new("std_msgs/Empty")]


def test_callers_close_with_their_registration_and_connection(endpoint: EndpointThread) -> None:
    bus = endpoint.backend
    assert isinstance(bus, WatchedBus)
    unity = RawClient(endpoint.port)
    for service in ("/a", "/b"):
        unity.send(registration("__ros_service", service, "std_srvs/Trigger"))
    unity.stats()
    assert bus.open_callers() == ["/a", "/b"]
    unity.send(unity_command("__remove_ros_service", '{"topic":"/b"}'))
    unity.send(registration("__ros_service", "/a", "std_srvs/Empty"))  # replaces the first
    unity.stats()
    assert bus.open_callers() == ["/a"]
    assert [(c.service, c.closed) for c in bus.callers] == [
        ("/a", True),
        ("/b", True),
        ("/a", False),
    ]
    other = RawClient(endpoint.port)
    other.send(registration("__ros_service", "/c", "std_srvs/Trigger"))
    other.stats()
    unity.close()
    assert wait_until(lambda: bus.open_callers() == ["/c"])
    other.close()
    assert wait_until(lambda: bus.open_callers() == [])
