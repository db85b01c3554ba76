"""The simulator through `simbridge endpoint --backend ros2` to real rclpy nodes.

The sim runs here (its connector takes the ROS 2 protocol from the handshake); the
endpoint and the ROS 2 nodes are processes of the ROS 2 venv with localhost-only DDS.
"""

from __future__ import annotations

import itertools
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
import yaml

from simbridge.sim.ros import SimulationSession
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
    the sim runs at 4x real time, so the ticks come 0.5 s of sim time apart."""
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
        runner = threading.Thread(target=session.run, kwargs={"realtime_factor": 4.0})
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
    # The first tick comes when the first /clock arrives; after it every 0.5 s of sim time,
    # give or take the /clock message (10 ms) that crossed the timer's deadline.
    gaps = [b - a for a, b in itertools.pairwise(seconds[1:])]
    assert all(g == pytest.approx(0.5, abs=0.025) for g in gaps), gaps
    assert seconds[-1] - seconds[1] == pytest.approx(0.5 * len(gaps), abs=0.025)
