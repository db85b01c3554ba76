"""Nothing accepted is lost: a client that publishes N Twists through the ROS 2 endpoint and
closes its socket at once, and a flat-out queue_size 0 stream.

A raw TCP client (this process) registers `__publish` of geometry_msgs/Twist (asking for
`__subscribers`), waits until a reliable keep-all rclpy subscriber (tests/ros2/
twist_counter.py, a process of its own) has matched, writes N frames in one go and shuts
its socket down (the endpoint reads to the end and closes its side); it closes the socket
once it has read what the endpoint sent (a socket closed with unread data is reset, and
the kernel drops what the client had not sent yet). The subscriber counts what arrives
and checks the order (message k carries linear.x == k). `drain_s` runs from the client's
shutdown to the last arrival (the endpoint draining DDS after the client left); `rate` is
messages received per second from the first byte sent to the last arrival. Run alone:
`python benchmarks/bench_drain.py` (SIMBRIDGE_BENCH_SCALE shrinks the counts).
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # also as a bare script

from simbridge.endpoint.backends.ros2 import ros2_python

__all__ = ["run"]

if ros2_python() is None:  # benchmarks/run.py reports the suite as skipped
    raise ModuleNotFoundError("the ROS 2 venv (.venv-ros2) is missing: run `make ros2`")

SCALE = float(os.environ.get("SIMBRIDGE_BENCH_SCALE", "1"))
COUNTER = Path(__file__).resolve().parents[1] / "tests" / "ros2" / "twist_counter.py"
QUIET = 8.0
"""Seconds without a message after which the subscriber stops counting."""

CASES = (
    # (label, messages, queue_size)
    ("publish then close, queue_size = N", 50_000, -1),
    ("publish then close, queue_size 10", 50_000, 10),
    ("flat-out stream, queue_size 0", 100_000, 0),
)


def measure(port: int, topic: str, count: int, queue_size: int) -> dict[str, Any]:
    """One case: sent, received, in order, drain time and rate."""
    from tests.endpoint.drainclient import publish_and_close
    from tests.ros2support import Ros2Process

    with Ros2Process([str(COUNTER), topic, str(count), str(QUIET)]) as counter:
        counter.expect_json("ready", timeout=60)
        sent = publish_and_close(port, topic, count, queue_size, cdr=True)
        began, closed = sent.began, sent.closed
        got = json.loads(counter.expect_line(r'^\{"count"', timeout=600 + QUIET).string)
    received = int(got["count"])
    last = float(got.get("last", closed)) if received else closed
    return {
        "sent": count,
        "received": received,
        "in_order": bool(got.get("in_order", False)),
        "drain_s": round(max(0.0, last - closed), 3),
        "rate_msg_s": round(received / (last - began)) if received and last > began else 0,
    }


def run() -> list[dict[str, Any]]:
    """Every case once against one `simbridge endpoint --backend ros2`."""
    from tests.ros2support import start_endpoint

    rows: list[dict[str, Any]] = []
    endpoint, port = start_endpoint("--idle-timeout", "0")
    try:
        for i, (label, count, queue_size) in enumerate(CASES):
            n = max(int(count * SCALE), 100)
            row = measure(port, f"/bench/drain{i}", n, n if queue_size < 0 else queue_size)
            rows.append({"case": label, **row})
            print(rows[-1], flush=True)
    finally:
        endpoint.stop()
    return rows


if __name__ == "__main__":
    from benchmarks.table import format_table
    from benchmarks.usage import exit_on_help

    exit_on_help(__doc__, "  --markdown  a Markdown table")
    print(format_table(run(), markdown="--markdown" in sys.argv))
