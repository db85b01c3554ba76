"""Every demo honours `--backend ros1`: its topics and services are on a real ROS 1 graph."""

from __future__ import annotations

import json
import statistics
import sys
import time
import xmlrpc.client
from collections.abc import Iterator
from typing import Any

import pytest
import yaml

from tests.ros1support import RosMaster, require_ros, terminate

pytestmark = [
    pytest.mark.ros1,
    pytest.mark.timeout(240),
    pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning"),
]

DEMO = [sys.executable, "-m", "simbridge.cli", "demo"]


@pytest.fixture(scope="module")
def master() -> Iterator[RosMaster]:
    require_ros()
    with RosMaster() as master:
        yield master


def publishers(master: RosMaster, topic: str) -> list[str]:
    reply: Any = xmlrpc.client.ServerProxy(master.uri).getSystemState("/test_demos_ros1")
    return [node for name, nodes in reply[2][0] for node in nodes if name == topic]


def test_mobile_robot_drives_over_real_ros_topics(master: RosMaster) -> None:
    """The sim's sensors and the driver's /cmd_vel cross the ROS 1 master: rostopic sees
    them while the robot drives, and the square still closes."""
    # Paced at 2x real time: a flat-out sim on a loaded machine can outrun the driver's
    # /odom -> /cmd_vel loop (that is the demo's timing, not the ROS path under test).
    demo = master.spawn([*DEMO, "mobile-robot", "--backend", "ros1", "--json", "--realtime", "2"])
    try:
        deadline = time.monotonic() + 120
        topics = ("/imu", "/odom", "/cmd_vel")  # the sim's sensors, the driver's commands
        while not all(publishers(master, topic) for topic in topics):
            assert demo.poll() is None, demo.communicate()
            assert time.monotonic() < deadline, f"the demo never published {topics}"
            time.sleep(0.1)
        (node,) = publishers(master, "/imu")
        assert node.startswith("/simbridge_mobile_robot_")  # a unique node name
        assert publishers(master, "/cmd_vel") == [node]
        assert publishers(master, "/odom") == [node]
        echo = master.run(["rostopic", "echo", "-n", "9", "/imu"], timeout=60)
        assert echo.returncode == 0, echo.stderr
        imus = [yaml.safe_load(doc) for doc in echo.stdout.split("---") if doc.strip()]
        assert {imu["header"]["frame_id"] for imu in imus} == {"imu_link"}
        # Gravity, robot upright: the median, as one sample may catch a bump while driving.
        z = statistics.median(imu["linear_acceleration"]["z"] for imu in imus)
        assert abs(z - 9.81) < 1.0, [imu["linear_acceleration"]["z"] for imu in imus]
        kind = master.run(["rostopic", "type", "/odom"])
        assert kind.stdout.strip() == "nav_msgs/Odometry"
        out, err = demo.communicate(timeout=180)
    finally:
        terminate(demo)
    assert demo.returncode == 0, out + err
    summary = json.loads(out.strip().splitlines()[-1])
    assert summary["success"] is True, out
    assert summary["odom_per_s"] > 45, out  # every /odom crossed rospy to the driver
    assert "ros1 backend, ROS master" in out
    assert not publishers(master, "/imu")  # unregistered on the way out


def test_bridge_demo_runs_through_the_master(master: RosMaster) -> None:
    result = master.run([*DEMO, "bridge", "--backend", "ros1"], timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "demo: 5/5 messages delivered, service call ok=True" in result.stdout
    assert "'/rosout': 'rosgraph_msgs/Log'" in result.stdout  # the topic list is the master's
    assert f"ROS master {master.uri} (found)" in result.stdout
