"""Mobile robot: diffbot drives a square in a walled room over ROS topics, sensors measured.

The simulation serves /cmd_vel (diff drive), /odom, /scan, /camera/... and /imu through
the endpoint (its local bus, or a ROS 1 master); an in-process driver node closes the loop
on /odom and tallies the sensors. `run_mobile_robot` runs the whole chain and returns a
`MobileRobotResult`.
"""

from __future__ import annotations

from simbridge.apps.mobile_robot.driver import (
    DriverNode,
    DriverTopics,
    ScanSample,
    SensorTally,
    SquarePath,
)
from simbridge.apps.mobile_robot.result import MobileRobotResult
from simbridge.apps.mobile_robot.runner import BASE_LINK, SCENE_PATH, main, run_mobile_robot

__all__ = [
    "BASE_LINK",
    "SCENE_PATH",
    "DriverNode",
    "DriverTopics",
    "MobileRobotResult",
    "ScanSample",
    "SensorTally",
    "SquarePath",
    "main",
    "run_mobile_robot",
]
