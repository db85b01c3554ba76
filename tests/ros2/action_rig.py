"""What the served-action tests drive: a `simbridge endpoint --backend ros2` and, beside it,
a plain rclpy action client process (tests/ros2/action_driver.py), both up."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

from tests.ros2support import ActionDriver, Ros2Process, require_ros2, start_endpoint

__all__ = ["ActionRig", "action_rig"]


@dataclass(frozen=True)
class ActionRig:
    """The endpoint's port and the action client process sending goals through ROS 2;
    `endpoint` is the endpoint's process (its log in `output`)."""

    port: int
    driver: ActionDriver
    endpoint: Ros2Process


def action_rig() -> Iterator[ActionRig]:
    """Start the endpoint, then the driver once the endpoint listens; stop both after."""
    require_ros2()
    proc, port = start_endpoint("--idle-timeout", "0")
    try:
        driver = ActionDriver()
        try:
            driver.expect(lambda o: o.get("up") is True)
            yield ActionRig(port, driver, proc)
        finally:
            driver.proc.stop()
    finally:
        proc.stop()
