"""`simbridge demo ... --backend ros2`: the demos over a real ROS 2 graph (localhost DDS).

Each demo runs as a process of the ROS 2 venv; an independent rclpy node
(tests/ros2/ros2_node.py) watches its topics, so they are real ROS 2 topics.
"""

from __future__ import annotations

import pytest

from tests.ros2support import Ros2Process

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(300)]

DEMO = ["-m", "simbridge.cli", "demo"]


def test_mobile_robot_drives_over_real_ros2_topics() -> None:
    """The sim's IMU reaches an rclpy node in another process while the driver (on the
    endpoint's rclpy node) closes the square over /odom and /cmd_vel."""
    with Ros2Process.node("echo", "/imu", "sensor_msgs/msg/Imu", "50") as echo:
        assert echo.expect_json("ready", timeout=60) is True
        with Ros2Process(
            [*DEMO, "mobile-robot", "--backend", "ros2", "--json", "--side", "0.5"]
        ) as demo:
            readings = [echo.expect_json("msg", timeout=120) for _ in range(50)]
            imu = readings[-1]  # half a second in: the wheels have settled on the floor
            assert imu["header"]["frame_id"] == "imu_link"
            assert abs(imu["linear_acceleration"]["z"] - 9.81) < 1.0  # gravity, robot upright
            assert set(imu["header"]["stamp"]) == {"sec", "nanosec"}  # ROS 2 layout
            completed = demo.expect_json("success", timeout=240)
            result = demo.output[-1]
    assert completed is True, "".join(demo.output[-20:])
    assert '"error": null' in result
    assert "ros2 backend" in "".join(demo.output)


def test_bridge_demo_over_ros2() -> None:
    """Twist messages and a service call between two connectors through rclpy."""
    with Ros2Process([*DEMO, "bridge", "--backend", "ros2", "--json"]) as demo:
        summary = demo.expect_line(r'^\{"success"', timeout=120).string  # the JSON summary
    assert '"success": true' in summary
    assert '"backend": "ros2"' in summary
    assert '"received": 5' in summary
    assert '"service_ok": true' in summary
