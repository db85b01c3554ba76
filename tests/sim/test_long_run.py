"""Long runs at full speed: every sensor and state topic at its nominal rate, no duplicate
stamps, as a subscriber on the endpoint sees them (issue 11, "done when").

`make test` runs a few minutes of sim time; the 30-minute run is marked `slow`
(`pytest -m slow tests/sim/test_long_run.py`).
"""

from __future__ import annotations

import threading
from collections import defaultdict
from pathlib import Path
from typing import Any

import pytest
import yaml

from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.sim.runner import SimulationSession
from tests.sim.urdf_samples import GRAVITY_ARM
from tests.waiting import wait_for

SCENE: dict[str, Any] = {
    "physics": {"timestep": 0.002, "realtime_factor": 0},
    "robots": [{"urdf": "arm.urdf", "initial_positions": {"shoulder": -0.3, "elbow": 0.5}}],
    "objects": [
        {"name": "floor", "type": "plane"},
        {"name": "puck", "type": "cylinder", "size": [0.05, 0.02], "dynamic": True,
         "pose": {"xyz": [1.0, 0.0, 0.02]}},
    ],
    "sensors": [
        {"type": "imu", "name": "imu", "body": "fore", "topic": "/imu", "rate": 100},
        {"type": "odometry", "name": "odom", "body": "puck", "topic": "/odom", "rate": 50},
        {"type": "lidar_2d", "name": "laser", "body": "upper", "topic": "/scan", "rate": 10,
         "samples": 36},
        {"type": "camera", "name": "cam", "body": "fore", "topic": "/cam", "rate": 5,
         "width": 16, "height": 12},
        {"type": "depth_camera", "name": "depth", "body": "upper", "topic": "/rgbd", "rate": 5,
         "width": 8, "height": 6},
        {"type": "lidar_3d", "name": "velo", "body": "base", "xyz": [0, 0, 1.2],
         "topic": "/points", "rate": 5, "channels": 2, "samples": 18},
    ],
    "ros": {"joint_states_rate": 50, "tf_rate": 50, "clock_rate": 100},
}  # fmt: skip

STREAMS = {
    "/joint_states": ("sensor_msgs/JointState", 50),
    "/tf world tree": ("tf2_msgs/TFMessage", 50),
    "/tf odom": ("tf2_msgs/TFMessage", 50),
    "/clock": ("rosgraph_msgs/Clock", 100),
    "/imu": ("sensor_msgs/Imu", 100),
    "/odom": ("nav_msgs/Odometry", 50),
    "/scan": ("sensor_msgs/LaserScan", 10),
    "/cam/image_raw": ("sensor_msgs/Image", 5),
    "/cam/camera_info": ("sensor_msgs/CameraInfo", 5),
    "/cam/image_raw/compressed": ("sensor_msgs/CompressedImage", 5),
    "/rgbd/depth/image": ("sensor_msgs/Image", 5),
    "/rgbd/depth/image_raw": ("sensor_msgs/Image", 5),
    "/rgbd/depth/points": ("sensor_msgs/PointCloud2", 5),
    "/rgbd/depth/camera_info": ("sensor_msgs/CameraInfo", 5),
    "/points": ("sensor_msgs/PointCloud2", 5),
}
"""Stream -> (type, nominal Hz). /tf carries two streams: the arm's joints and odom."""


def _ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def run_and_count(tmp_path: Path, sim_seconds: float) -> dict[str, list[int]]:
    """Run the scene unpaced for `sim_seconds` and return each stream's stamps (ns), in
    the order a local-bus subscriber received them."""
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(SCENE))
    stamps: dict[str, list[int]] = defaultdict(list)
    lock = threading.Lock()

    def keep(topic: str) -> Any:
        def store(msg: Any) -> None:
            if topic == "/clock":
                key, stamp = topic, msg.clock
            elif topic == "/tf":
                frames = {t.header.frame_id for t in msg.transforms}
                key = "/tf odom" if frames == {"odom"} else "/tf world tree"
                stamp = msg.transforms[0].header.stamp
            else:
                key, stamp = topic, msg.header.stamp
            with lock:
                stamps[key].append(_ns(stamp))

        return store

    with EndpointThread(EndpointOptions(port=0)) as endpoint:
        assert isinstance(endpoint.backend, LocalBus)
        with Node(endpoint.backend, "/counter") as node:
            for topic, msg_type in {s.split()[0]: t for s, (t, _) in STREAMS.items()}.items():
                node.subscribe(topic, msg_type, keep(topic))
            address = f"127.0.0.1:{endpoint.port}"
            with SimulationSession(tmp_path / "scene.yaml", address, connect_timeout=5) as sim:
                assert sim.connector is not None
                assert sim.sensors is not None
                lazy = sim.sensors
                assert all(
                    wait_for(lambda t=t: lazy.publisher(t).has_subscribers)  # type: ignore[misc]
                    for t in lazy.suite.outputs
                    if t != "/tf"
                )
                stats = sim.run(duration=sim_seconds, realtime_factor=0)
                assert stats.steps == round(sim_seconds / 0.002)
                assert sim.connector.flush(60)
                drops = sim.connector.stats().publish_drops
            expected = sum(round(sim_seconds * hz) for _, hz in STREAMS.values())
            wait_for(lambda: sum(len(v) for v in stamps.values()) >= expected, timeout=60)
    assert not drops, drops
    return dict(stamps)


def check_rates(stamps: dict[str, list[int]], sim_seconds: float) -> None:
    assert set(stamps) == set(STREAMS)
    for stream, (_, hz) in STREAMS.items():
        got = stamps[stream]
        nominal = sim_seconds * hz
        print(f"{stream}: {len(got)} in {sim_seconds:g} s = {len(got) / sim_seconds:.4f} Hz")
        assert abs(len(got) - nominal) <= 0.005 * nominal, (stream, len(got), nominal)
        assert len(set(got)) == len(got), f"{stream}: duplicate stamps"
        assert got == sorted(got), f"{stream}: stamps out of order"
        step_ns = 2_000_000
        assert all(s % step_ns == 0 for s in got), f"{stream}: stamp off the step grid"


def test_every_topic_at_its_rate_for_minutes(tmp_path: Path) -> None:
    seconds = 120.0  # past the ~82 s where float schedules used to double up
    check_rates(run_and_count(tmp_path, seconds), seconds)


@pytest.mark.slow
@pytest.mark.timeout(3600)
def test_every_topic_at_its_rate_for_half_an_hour(tmp_path: Path) -> None:
    seconds = 1800.0
    check_rates(run_and_count(tmp_path, seconds), seconds)
