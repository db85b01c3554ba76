"""The simulator through `simbridge endpoint --backend ros2` to real rclpy nodes.

The sim runs here (its connector takes the ROS 2 protocol from the handshake); the
endpoint and the ROS 2 nodes are processes of the ROS 2 venv with localhost-only DDS.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml

from simbridge.sim.runner import SimulationSession
from tests.ros2support import Ros2Process, start_endpoint
from tests.sim.urdf_samples import GRAVITY_ARM

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(240)]

CLOCK_FOLLOWER = Path(__file__).parent / "clock_follower.py"


@pytest.fixture
def endpoint() -> Iterator[int]:
    proc, port = start_endpoint("--idle-timeout", "0")
    try:
        yield port
    finally:
        proc.stop()


def _arm_scene(tmp_path: Path) -> Path:
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    scene = {"robots": [{"urdf": "arm.urdf"}], "ros": {"tf": False, "clock_rate": 100}}
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    return tmp_path / "scene.yaml"


def test_sim_clock_drives_a_node_with_use_sim_time(tmp_path: Path, endpoint: int) -> None:
    """A 0.5 s timer of a use_sim_time node fires on the sim's /clock, not on wall time:
    the ticks come 0.5 s of sim time apart, and carry sim time."""
    ticks_wanted = 7
    with (
        SimulationSession(
            _arm_scene(tmp_path), f"127.0.0.1:{endpoint}", connect_timeout=10
        ) as session,
        Ros2Process(
            [str(CLOCK_FOLLOWER), str(ticks_wanted), "--ros-args", "-p", "use_sim_time:=true"]
        ) as follower,
    ):
        assert session.connector is not None
        assert session.connector.protocol == "ROS2"
        ready = follower.expect_json("ready", timeout=60)
        assert ready is True
        runner = threading.Thread(target=session.run, kwargs={"realtime_factor": 1.0})
        runner.start()
        try:
            ticks = [follower.expect_json("tick", timeout=30) for _ in range(ticks_wanted)]
            sim_now = session.world.time
        finally:
            session.world.stop()
            runner.join(10)
    assert '"use_sim_time": true' in "".join(follower.output)
    seconds = [t * 1e-9 for t in ticks]
    assert seconds == sorted(seconds)
    assert all(0.0 < s <= sim_now + 1e-9 for s in seconds)  # sim time, not the wall clock
    # The first tick comes when the first /clock arrives; after it one every 0.5 s of sim
    # time. A tick lands on the first /clock the node handles past its deadline, which on
    # a loaded machine may come late (rclpy then handles /clock in batches).
    offsets = [s - seconds[1] for s in seconds[1:]]
    assert [round(o / 0.5) for o in offsets] == list(range(len(offsets))), offsets


def test_rclpy_decodes_what_the_sim_publishes(tmp_path: Path, endpoint: int) -> None:
    """JointState and a camera's CameraInfo (d k r p, Header without seq), as rclpy reads them."""
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    camera = {"type": "camera", "name": "cam", "body": "fore", "topic": "/cam", "rate": 20,
              "width": 32, "height": 24}  # fmt: skip
    scene = {"robots": [{"urdf": "arm.urdf"}], "ros": {"tf": False}, "sensors": [camera]}
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    info_type, states_type = "sensor_msgs/msg/CameraInfo", "sensor_msgs/msg/JointState"
    with (
        Ros2Process.node("echo", "/cam/camera_info", info_type, "1") as info_echo,
        Ros2Process.node("echo", "/joint_states", states_type, "1") as states_echo,
    ):
        assert info_echo.expect_json("ready", timeout=60) is True
        assert states_echo.expect_json("ready", timeout=60) is True
        address = f"127.0.0.1:{endpoint}"
        with SimulationSession(tmp_path / "scene.yaml", address, connect_timeout=10) as session:
            runner = threading.Thread(target=session.run, kwargs={"realtime_factor": 1.0})
            runner.start()
            try:
                info = info_echo.expect_json("msg", timeout=60)
                states = states_echo.expect_json("msg", timeout=60)
            finally:
                session.world.stop()
                runner.join(10)
    assert set(info["header"]) == {"stamp", "frame_id"}  # no seq in ROS 2
    assert info["header"]["frame_id"] == "fore_optical_frame"
    assert (info["width"], info["height"], info["distortion_model"]) == (32, 24, "plumb_bob")
    assert info["d"] == [0.0] * 5
    fx, cx, fy, cy = info["k"][0], info["k"][2], info["k"][4], info["k"][5]
    assert (cx, cy) == (15.5, 11.5)
    assert fx == pytest.approx(fy)
    assert info["p"][0] == fx
    assert info["r"] == [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    assert states["name"]
    assert len(states["position"]) == len(states["name"])
    assert states["header"]["stamp"]["sec"] >= 0
