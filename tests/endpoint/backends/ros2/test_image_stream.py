"""Images back to back, both ways. Sim -> ROS 2: each arrives intact although the endpoint
receives the next image into the buffer the last one was published from
(FrameDecoder.recycle). ROS 2 -> sim: each arrives intact although the endpoint takes the
next large one into the buffer the last one was written to the client from
(`backends.ros2.rcl.DirectTake`), whether the client reads at once or stalls (then it is copied).

The endpoint is a subprocess (ROS 2 venv); CDR comes from rosbags' Jazzy type store.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore
from tests.endpoint.rawclient import RawClient
from tests.ros2support import Ros2Process, require_ros2, start_endpoint

from simbridge.protocol import MessageReceived, ProtocolConnection, Publish, Subscribe

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(240)]

TS = get_typestore(Stores.ROS2_JAZZY)


def _image(width: int, height: int, seed: int) -> tuple[bytes, list[int]]:
    """A sensor_msgs/Image rgb8 in CDR (over 64 KiB, so the endpoint lends its buffer)."""
    pixels = ((np.arange(width * height * 3) + 37 * seed) % 251).astype(np.uint8)
    stamp = TS.types["builtin_interfaces/msg/Time"](sec=seed, nanosec=seed)
    msg = TS.types["sensor_msgs/msg/Image"](
        header=TS.types["std_msgs/msg/Header"](stamp=stamp, frame_id=f"cam{seed}"),
        height=height,
        width=width,
        encoding="rgb8",
        is_bigendian=0,
        step=width * 3,
        data=pixels,
    )
    return bytes(TS.serialize_cdr(msg, "sensor_msgs/msg/Image")), pixels.tolist()


def test_back_to_back_images_arrive_intact() -> None:
    """Five images in one write, the fourth of another size: every one reaches the ROS 2
    subscriber with its own stamp and pixels, in order."""
    require_ros2()
    sizes = [(160, 160), (160, 160), (160, 160), (200, 160), (160, 160)]
    images = [_image(w, h, seed) for seed, (w, h) in enumerate(sizes, start=1)]
    assert min(len(cdr) for cdr, _ in images) > 64 * 1024
    endpoint, port = start_endpoint("--idle-timeout", "0")
    client = RawClient(port)
    try:
        with Ros2Process.node("echo", "/sb_stream", "sensor_msgs/msg/Image", "5") as echo:
            echo.expect_json("ready")
            advertise = Publish("/sb_stream", "sensor_msgs/Image", report_subscribers=True)
            client.send(advertise.encode())
            client.wait_subscribers(timeout=20)
            client.send(
                b"".join(ProtocolConnection.message("/sb_stream", cdr) for cdr, _ in images)
            )
            got = [echo.expect_json("msg", timeout=30) for _ in images]
    finally:
        client.close()
        endpoint.stop()
    for seed, (msg, (width, height), (_, pixels)) in enumerate(
        zip(got, sizes, images, strict=True), start=1
    ):
        assert msg["header"] == {"stamp": {"sec": seed, "nanosec": seed}, "frame_id": f"cam{seed}"}
        assert (msg["width"], msg["height"]) == (width, height)
        assert msg["data"] == pixels


WIDTHS = (921_600, 1_000, 921_600, 200_000, 65_000, 65_536, 10, 500_000)
"""Large images (lent by the endpoint's take) and small ones (taken as bytes) in turn."""


def _pixels(seed: int, width: int) -> bytes:
    row = bytes((seed + k) % 251 for k in range(251))
    return row * (width // 251) + row[: width % 251]


def _receive_images(client: RawClient, topic: str, count: int) -> list[Any]:
    got: list[Any] = []
    deadline = time.monotonic() + 90
    while len(got) < count and time.monotonic() < deadline:
        client.poll(0.2)
        for event in client.events:
            if isinstance(event, MessageReceived) and event.topic == topic:
                got.append(TS.deserialize_cdr(bytes(event.payload), "sensor_msgs/msg/Image"))
        client.events.clear()
    return got


@pytest.mark.parametrize("stall", [0.0, 3.0], ids=["reading", "stalled"])
def test_ros2_images_reach_the_client_intact(stall: float) -> None:
    """A ROS 2 burst of images, large and small in turn, reaches a client whole and in
    order: read as it comes, or after the client read nothing for `stall` seconds (the
    endpoint's writes to it back up and it queues copies of the lent images)."""
    require_ros2()
    count = 3 * len(WIDTHS)  # ~11 MB: more than the loopback socket buffers hold
    endpoint, port = start_endpoint("--idle-timeout", "0")
    client = RawClient(port)
    try:
        client.send(Subscribe("/sb_images", "sensor_msgs/Image", queue_size=count).encode())
        widths = ",".join(map(str, WIDTHS))
        with Ros2Process.node("images", "/sb_images", str(count), widths) as publisher:
            if stall:
                time.sleep(stall)
            got = _receive_images(client, "/sb_images", count)
            assert publisher.expect_json("sent", timeout=60) == count
    finally:
        client.close()
        endpoint.stop()
    assert [msg.header.stamp.sec for msg in got] == list(range(count))
    for seed, msg in enumerate(got):
        width = WIDTHS[seed % len(WIDTHS)]
        assert msg.width == width
        assert msg.data.tobytes() == _pixels(seed, width), f"image {seed} differs"
