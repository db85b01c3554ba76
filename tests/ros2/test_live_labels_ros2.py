"""Live labels to real rclpy subscribers, through `simbridge endpoint --backend ros2` and
from `simbridge sim --ros2` (the sim as its own node): the camera's
vision_msgs/Detection2DArray (built into the ROS 2 venv from the shipped definitions) and
its instance segmentation, as rclpy decodes them."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from simbridge.sim.runner import SimulationSession
from simbridge.sim.sensors import Camera, SensorSuite
from simbridge.sim.world import World
from tests.ros2support import Ros2Process, child_env, start_endpoint
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
    _check(array, image, expected)


def _check(array: dict[str, Any], image: dict[str, Any], expected: tuple[float, ...]) -> None:
    """The detections and instance image rclpy decoded against the crate's projection."""
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


def test_the_sim_as_its_own_node_publishes_labels(tmp_path: Path) -> None:
    """`simbridge sim SCENE --ros2`: the same labels straight from the sim's rclpy node."""
    scene = labelled_scene(tmp_path)
    world = World.from_scene(scene)  # the static scene as the sim's process poses it
    suite = SensorSuite.from_config(world.model, world.scene.sensors)
    camera = suite["cam"]
    assert isinstance(camera, Camera)
    world.refresh()
    expected = crate_pixel_box(world, camera)
    suite.close()
    detections_type, image_type = "vision_msgs/msg/Detection2DArray", "sensor_msgs/msg/Image"
    env = {**child_env(), "MUJOCO_GL": "osmesa", "PYOPENGL_PLATFORM": "osmesa"}
    with (
        Ros2Process.node("echo", f"{CAMERA_TOPIC}/detections", detections_type, "1") as boxes,
        Ros2Process.node("echo", f"{CAMERA_TOPIC}/instances", image_type, "1") as ids,
    ):
        assert boxes.expect_json("ready", timeout=60) is True
        assert ids.expect_json("ready", timeout=60) is True
        with Ros2Process(["-m", "simbridge.cli", "sim", str(scene), "--ros2"], env=env) as sim:
            try:
                array = boxes.expect_json("msg", timeout=120)
                image = ids.expect_json("msg", timeout=60)
            except AssertionError as exc:
                sim.stop(timeout=30)
                raise AssertionError(f"{exc}\nsim output:\n{''.join(sim.output)[-3000:]}") from None
            sim.stop(timeout=30)
    _check(array, image, expected)
