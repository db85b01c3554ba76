"""ROS interfaces of the simulator, through the connector: joint states, TF, clock, commands."""

from __future__ import annotations

from simbridge.sim.ros.bridge import SimRosBridge
from simbridge.sim.ros.cmd_vel_controller import CmdVelController, measure_wheels
from simbridge.sim.ros.commands import CommandSubscriber
from simbridge.sim.ros.convert import (
    StampMaker,
    duration_seconds,
    joint_state_message,
    tf_message,
    trajectory_from_message,
)
from simbridge.sim.ros.gripper_controller import GripperActionController
from simbridge.sim.ros.group_controller import GroupCommandController
from simbridge.sim.ros.names import RobotNames, resolve_name
from simbridge.sim.ros.params import description_params
from simbridge.sim.ros.robot_bridge import RobotBridge
from simbridge.sim.ros.sensor_publisher import SensorPublisher
from simbridge.sim.ros.services import STEP_SRV, ControlServices
from simbridge.sim.ros.state_publisher import StatePublisher
from simbridge.sim.ros.trajectory_controller import JointTrajectoryController

__all__ = [
    "STEP_SRV",
    "CmdVelController",
    "CommandSubscriber",
    "ControlServices",
    "GripperActionController",
    "GroupCommandController",
    "JointTrajectoryController",
    "RobotBridge",
    "RobotNames",
    "SensorPublisher",
    "SimRosBridge",
    "StampMaker",
    "StatePublisher",
    "description_params",
    "duration_seconds",
    "joint_state_message",
    "measure_wheels",
    "resolve_name",
    "tf_message",
    "trajectory_from_message",
]
