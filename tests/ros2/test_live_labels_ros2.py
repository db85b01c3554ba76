"""Live labels through `simbridge endpoint --backend ros2` to real rclpy subscribers: the
camera's vision_msgs/Detection2DArray (built into the ROS 2 venv from the shipped
definitions) and its instance segmentation, as rclpy decodes them."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from simbridge.sim.runner import SimulationSession
from simbridge.sim.sensors import Camera
from tests.ros2support import Ros2Process, start_endpoint
from tests.sim.sensors.labelled_scene import (
    CAMERA_TOPIC,
    HEIGHT,
    WIDTH,
    crate_pixel_box,
    labelled_scene,
)

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(240)]


@pytest.fixture
def endpoint() -> Iterator[int]:
    proc, port = start_endpoint("--idle-timeout", "0")
    try:
        yield port
    finally:
        proc.stop()


def test_rclpy_receives_detections_and_segmentation(tmp_path: Path, endpoint: int) -> None:
    detections_type, image_type = "vision_msgs/msg/Detection2DArray", "sensor_msgs/msg/Image"
    with (
        Ros2Process.node("echo", f"{CAMERA_TOPIC}/detections", detections_type, "1") as boxes,
        Ros2Process.node("echo", f"{CAMERA_TOPIC}/instances", image_type, "1") as ids,
    ):
        assert boxes.expect_json("ready", timeout=60) is True
        assert ids.expect_json("ready", timeout=60) is True
        address = f"127.0.0.1:{endpoint}"
        with SimulationSession(labelled_scene(tmp_path), address, connect_timeout=10) as session:
            assert session.connector is not None
            assert session.connector.protocol == "ROS2"
            assert session.sensors is not None
            camera = session.sensors.suite["cam"]
            assert isinstance(camera, Camera)
            expected = crate_pixel_box(session.world, camera)
            runner = threading.Thread(target=session.run, kwargs={"realtime_factor": 1.0})
            runner.start()
            try:
                array = boxes.expect_json("msg", timeout=60)
                image = ids.expect_json("msg", timeout=60)
            finally:
                session.world.stop()
                runner.join(10)
    assert set(array["header"]) == {"stamp", "frame_id"}  # ROS 2's Header
    assert array["header"]["frame_id"] == "cam_optical_frame"
    by_id = {int(d["id"]): d for d in array["detections"]}
    assert {i: d["results"][0]["hypothesis"]["class_id"] for i, d in by_id.items()} == {
        1: "crate",
        2: "ball",
        3: "post",
    }
    assert all(d["results"][0]["hypothesis"]["score"] == 1.0 for d in by_id.values())
    crate = by_id[1]["bbox"]
    centre, size = crate["center"]["position"], (crate["size_x"], crate["size_y"])
    edges = (
        centre["x"] - (size[0] - 1) / 2,
        centre["y"] - (size[1] - 1) / 2,
        centre["x"] + (size[0] - 1) / 2,
        centre["y"] + (size[1] - 1) / 2,
    )
    for got, want in zip(edges, expected, strict=True):
        assert abs(got - want) <= 1.0, (edges, expected)
    assert (image["encoding"], image["width"], image["height"]) == ("16UC1", WIDTH, HEIGHT)
    pixels = np.frombuffer(bytes(image["data"]), dtype="<u2").reshape(HEIGHT, WIDTH)
    assert set(np.unique(pixels)) == {0, 1, 2, 3}
    rows, cols = np.nonzero(pixels == 1)
    assert (cols.min(), rows.min(), cols.max(), rows.max()) == tuple(round(e) for e in edges)
