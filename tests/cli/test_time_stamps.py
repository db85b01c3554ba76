"""`simbridge topic pub/echo` with ROS 1 stamps past 2038 (uint32 seconds), on a live endpoint."""

from __future__ import annotations

import importlib
import io
import queue
from collections.abc import Iterator
from typing import Any

import pytest

from simbridge.cli import main
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.messages import default_registry

genpy = pytest.importorskip("genpy")


@pytest.fixture
def endpoint() -> Iterator[EndpointThread]:
    with EndpointThread(EndpointOptions(port=0)) as ep:
        yield ep


def _genpy_header(secs: int, nsecs: int, frame: str) -> bytes:
    header = importlib.import_module("std_msgs.msg").Header(
        stamp=genpy.Time(secs, nsecs), frame_id=frame
    )
    buff = io.BytesIO()
    header.serialize(buff)
    return buff.getvalue()


def test_topic_pub_stamp_past_2038(endpoint: EndpointThread) -> None:
    assert isinstance(endpoint.backend, LocalBus)
    inbox: queue.Queue[Any] = queue.Queue()
    with Node(endpoint.backend, "/listener") as node:
        node.subscribe("/stamp", "std_msgs/Header", inbox.put)
        code = main(
            [
                "topic",
                "pub",
                "/stamp",
                "std_msgs/Header",
                "{stamp: {secs: 4294967295, nsecs: 7}, frame_id: late}",
                "--endpoint",
                f"127.0.0.1:{endpoint.port}",
            ]
        )
        assert code == 0
        received = inbox.get(timeout=10)
    assert (received.stamp.sec, received.stamp.nanosec) == (2**32 - 1, 7)
    assert default_registry().encode(received) == _genpy_header(2**32 - 1, 7, "late")


def test_topic_pub_out_of_range_stamp_is_a_clear_error(
    endpoint: EndpointThread, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(
        [
            "topic",
            "pub",
            "/stamp",
            "std_msgs/Header",
            "{stamp: {secs: 4294967296}}",
            "--endpoint",
            f"127.0.0.1:{endpoint.port}",
        ]
    )
    assert code == 2
    err = capsys.readouterr().err
    assert "std_msgs/Header.stamp: time seconds 4294967296 out of range [0, 4294967295]" in err


def test_topic_echo_prints_stamp_past_2038(
    endpoint: EndpointThread, capsys: pytest.CaptureFixture[str]
) -> None:
    assert isinstance(endpoint.backend, LocalBus)
    registry = default_registry()
    with Node(endpoint.backend, "/talker") as node:
        pub = node.advertise("/stamp", "std_msgs/Header", latch=True)
        pub.publish(registry.decode(_genpy_header(4_000_000_000, 5, "x"), "std_msgs/Header"))
        code = main(
            [
                "topic",
                "echo",
                "/stamp",
                "-n",
                "1",
                "--duration",
                "10",
                "--endpoint",
                f"127.0.0.1:{endpoint.port}",
            ]
        )
    assert code == 0
    assert "stamp: {secs: 4000000000, nsecs: 5}" in capsys.readouterr().out
