"""Images sim -> ROS 2 back to back: each arrives intact although the endpoint receives
the next image into the buffer the last one was published from (FrameDecoder.recycle).

The endpoint is a subprocess (ROS 2 venv); CDR comes from rosbags' Jazzy type store.
"""

from __future__ import annotations

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from simbridge.protocol import ProtocolConnection, Publish
from tests.endpoint.rawclient import RawClient
from tests.ros2support import Ros2Process, require_ros2, start_endpoint

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
