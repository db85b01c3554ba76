"""Nothing accepted is lost on ROS 2: a client that publishes N Twists and leaves at once has
all N delivered (its publisher drained before it is destroyed), and a flat-out queue_size
0 stream (reliable keep-all, the client pushed back on while DDS has too many samples
unacknowledged) arrives whole and in order, against a real rclpy subscriber process
(tests/ros2/twist_counter.py)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from tests.endpoint.drainclient import publish_and_close
from tests.ros2support import Ros2Process, require_ros2, start_endpoint

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(300)]

COUNTER = Path(__file__).parents[3] / "ros2" / "twist_counter.py"
QUIET = 30.0
"""Seconds without a message after which the counter gives up (a loaded machine)."""
STREAM = 100_000
"""The flat-out queue_size 0 stream (about 7 s here on 2 busy cores)."""


@pytest.fixture(scope="module")
def port() -> Iterator[int]:
    require_ros2()
    # A drain bound no loaded machine reaches: the test counts messages, not seconds.
    endpoint, port = start_endpoint("--idle-timeout", "0", "--drain-timeout", "120")
    yield port
    endpoint.stop()


def _deliver(
    port: int, topic: str, count: int, queue_size: int, go: Path | None = None
) -> tuple[dict[str, Any], Any]:
    """Publish `count` Twists on `topic` and leave; what the subscriber got and `__stats`.
    With `go`, the subscriber takes nothing until the client has left."""
    args = [str(COUNTER), topic, str(count), str(QUIET), *([str(go)] if go else [])]
    with Ros2Process(args) as counter:
        counter.expect_json("ready", timeout=60)
        sent = publish_and_close(port, topic, count, queue_size, cdr=True, stats=True)
        if go is not None:
            go.touch()
        line = counter.expect_line(r'^\{"count"', timeout=240)
    got: dict[str, Any] = json.loads(line.string)
    return got, sent.stats


@pytest.mark.parametrize(("count", "queue_size"), [(20_000, 20_000), (10, 10)])
def test_publish_then_close_delivers_everything(
    port: int, count: int, queue_size: int, tmp_path: Path
) -> None:
    """The issue's case, smaller: a history as deep as the burst, the client gone at once,
    and the subscriber taking nothing until then (DDS holds about 10,000 samples for a
    subscriber that is not taking: the publisher destroyed at once lost the rest)."""
    go = tmp_path / "go"
    got, stats = _deliver(port, f"/drain/q{queue_size}", count, queue_size, go)
    assert (got["count"], got["in_order"]) == (count, True)
    assert stats["session"]["published"] == {f"/drain/q{queue_size}": count}


def test_a_flat_out_lossless_stream_arrives_whole(port: int) -> None:
    got, stats = _deliver(port, "/drain/lossless", STREAM, 0)
    assert (got["count"], got["in_order"]) == (STREAM, True)
    assert stats["session"]["published_total"] == STREAM
    counters = stats["server"]["backend_counters"]
    assert counters["publish_errors"] == 0
    assert counters["lossless_dropped"] == 0
    assert counters["lossless_pushbacks"] > 0  # the client was pushed back on, never dropped
