"""Throughput and latency through the endpoint with the local backend, end to end.

The endpoint runs in its own process (as it would in use); a publishing connector and
a subscribing connector run in this one. Figures: small messages/s, 640x480 rgb8 image
MB/s, round-trip latency p50/p99, and loss.
"""

from __future__ import annotations

import contextlib
import os
import statistics
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from simbridge.connector import Connector, ConnectorOptions
from simbridge.messages import default_registry

BIG_QUEUE = 1_000_000
BENCH_MEMORY_MB = 4096
"""The publisher sends as fast as it can with no pacing, so a subscriber that falls behind
(a busy machine) leaves a backlog in the endpoint: a budget of 4 GiB (512 MiB per client)
holds it rather than dropping (the default, 1024 MiB, would drop beyond ~140 images)."""
OPTS = ConnectorOptions(publish_queue_size=BIG_QUEUE, subscribe_queue_size=BIG_QUEUE)


def _start_endpoint() -> tuple[subprocess.Popen[str], int]:
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "simbridge.cli",
            "--log-level",
            "WARNING",
            "endpoint",
            "--port",
            "0",
            "--max-memory-mb",
            str(BENCH_MEMORY_MB),
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    line = proc.stdout.readline()
    port = int(line.split("127.0.0.1:")[1].split()[0])
    return proc, port


def _wait_topic(conn: Connector, topic: str) -> None:
    deadline = time.monotonic() + 5
    while topic not in conn.topic_list() and time.monotonic() < deadline:
        time.sleep(0.02)


def _throughput(
    port: int, topic: str, msg_type: str, payload: bytes, count: int, *, subscribers: int = 1
) -> dict[str, Any]:
    """One publisher to `subscribers` subscribers; rates are per subscriber (each gets all)."""
    done = [threading.Event() for _ in range(subscribers)]
    received = [0] * subscribers

    def counter(index: int) -> Callable[[bytes], None]:
        def on_msg(data: bytes) -> None:
            received[index] += 1
            if received[index] == count:
                done[index].set()

        return on_msg

    with contextlib.ExitStack() as stack:
        subs = [
            stack.enter_context(Connector("127.0.0.1", port, OPTS).connect())
            for _ in range(subscribers)
        ]
        pub_conn = stack.enter_context(Connector("127.0.0.1", port, OPTS).connect())
        for i, sub in enumerate(subs):
            sub.subscribe(topic, msg_type, counter(i), raw=True, queue_size=BIG_QUEUE)
        pub = pub_conn.register_publisher(topic, msg_type, queue_size=BIG_QUEUE)
        _wait_topic(subs[0], topic)
        time.sleep(0.2)
        start = time.perf_counter()
        for _ in range(count):
            pub.publish(payload)
        for event in done:
            event.wait(120)
        elapsed = time.perf_counter() - start
        dropped = sum(pub_conn.stats().publish_drops.values()) + sum(
            sum(sub.stats().subscribe_drops.values()) for sub in subs
        )
        ep_stats = subs[0].endpoint_stats()
    got = min(received)
    return {
        "received": got,
        "sent": count,
        "seconds": elapsed,
        "msg_per_s": got / elapsed,
        "mb_per_s": got * len(payload) / elapsed / 1e6,
        "lost": count * subscribers - sum(received),
        "connector_drops": dropped,
        "endpoint_drops": ep_stats["server"]["dropped_total"],
    }


def _latency(port: int, rounds: int) -> dict[str, float]:
    reg = default_registry()
    payload = reg.encode(reg.new("std_msgs/Header"))
    got = threading.Event()
    samples: list[float] = []
    with (
        Connector("127.0.0.1", port, OPTS).connect() as a,
        Connector("127.0.0.1", port, OPTS).connect() as b,
    ):
        pong = b.register_publisher("/pong", "std_msgs/Header")
        b.subscribe("/ping", "std_msgs/Header", pong.publish, raw=True)
        a.subscribe("/pong", "std_msgs/Header", lambda data: got.set(), raw=True)
        ping = a.register_publisher("/ping", "std_msgs/Header")
        _wait_topic(a, "/ping")
        _wait_topic(a, "/pong")
        time.sleep(0.2)
        for _ in range(rounds):
            got.clear()
            t0 = time.perf_counter()
            ping.publish(payload)
            if got.wait(2):
                samples.append((time.perf_counter() - t0) * 1e6)
    samples.sort()
    return {
        "p50_us": statistics.median(samples),
        "p99_us": samples[int(len(samples) * 0.99) - 1],
    }


def run(
    small_count: int = 200_000, image_count: int = 1_000, rounds: int = 2_000, repeats: int = 3
) -> list[dict[str, Any]]:
    """Measure everything `repeats` times; rows give the best and the median run."""
    reg = default_registry()
    twist = reg.new("geometry_msgs/Twist")
    twist.linear.x = 0.5
    small = reg.encode(twist)
    image = reg.new("sensor_msgs/Image", height=480, width=640, encoding="rgb8", step=640 * 3)
    image.data = np.frombuffer(os.urandom(640 * 480 * 3), dtype=np.uint8)
    image_bytes = reg.encode(image)
    load = os.getloadavg()[0]
    proc, port = _start_endpoint()
    smalls, images, pairs, lats = [], [], [], []
    try:
        for _ in range(repeats):
            smalls.append(_throughput(port, "/cmd_vel", "geometry_msgs/Twist", small, small_count))
            images.append(
                _throughput(
                    port, "/camera/image_raw", "sensor_msgs/Image", image_bytes, image_count
                )
            )
            pairs.append(
                _throughput(
                    port,
                    "/camera/image_pair",
                    "sensor_msgs/Image",
                    image_bytes,
                    image_count,
                    subscribers=2,
                )
            )
            lats.append(_latency(port, rounds))
    finally:
        proc.terminate()
        proc.wait(10)

    def row(figure: str, values: list[float], unit: str, target: str, lost: int) -> dict[str, Any]:
        return {
            "figure": figure,
            "best": max(values) if unit != "us" else min(values),
            "median": statistics.median(values),
            "unit": unit,
            "target": target,
            "lost": lost,
        }

    lost_small = sum(r["lost"] + r["connector_drops"] + r["endpoint_drops"] for r in smalls)
    lost_image = sum(r["lost"] + r["connector_drops"] + r["endpoint_drops"] for r in images)
    lost_pair = sum(r["lost"] + r["connector_drops"] + r["endpoint_drops"] for r in pairs)
    return [
        row(
            "small msgs (Twist, 48 B) end to end",
            [r["msg_per_s"] for r in smalls],
            "msg/s",
            ">= 50,000",
            lost_small,
        ),
        row(
            "640x480 rgb8 Image end to end",
            [r["mb_per_s"] for r in images],
            "MB/s",
            ">= 1,000",
            lost_image,
        ),
        row(
            "640x480 rgb8 Image end to end",
            [r["msg_per_s"] for r in images],
            "frames/s",
            "",
            lost_image,
        ),
        row(
            "640x480 rgb8 Image, 2 subscribers (each)",
            [r["mb_per_s"] for r in pairs],
            "MB/s",
            "",
            lost_pair,
        ),
        row("round trip ping/pong, p50", [r["p50_us"] for r in lats], "us", "", 0),
        row("round trip ping/pong, p99", [r["p99_us"] for r in lats], "us", "", 0),
        row("machine load average at start (2 cores)", [load], "", "", 0),
    ]


if __name__ == "__main__":
    from benchmarks.table import format_table

    print(format_table(run(), markdown="--markdown" in sys.argv))
