"""One namespaced robot's own ROS interface: <ns>/joint_states (URDF joint names) and its
command topics in its namespace. TF for its frames goes out on the shared /tf with the
scene's other robots (`StatePublisher`)."""

from __future__ import annotations

import logging
from dataclasses import replace

from simbridge.connector import Connector
from simbridge.errors import SimError
from simbridge.messages import MessageRegistry, WireFormat
from simbridge.protocol import ACTION_SERVERS_EXTENSION
from simbridge.sim.ros.cmd_vel_controller import CmdVelController
from simbridge.sim.ros.commands import CommandSubscriber
from simbridge.sim.ros.convert import StampMaker, joint_state_message
from simbridge.sim.ros.gripper_controller import GripperActionController
from simbridge.sim.ros.group_controller import GroupCommandController
from simbridge.sim.ros.joint_state_encoder import JointStateEncoder
from simbridge.sim.ros.names import RobotNames, resolve_name
from simbridge.sim.ros.trajectory_controller import JointTrajectoryController
from simbridge.sim.scene.spec import (
    GripperControllerSpec,
    GroupControllerSpec,
    RosSettings,
    TrajectoryControllerSpec,
)
from simbridge.sim.world.callbacks import CallbackHandle
from simbridge.sim.world.robot import RobotHandle
from simbridge.sim.world.world import World

_log = logging.getLogger("simbridge.sim.ros")

__all__ = ["RobotBridge"]


Controller = JointTrajectoryController | GripperActionController | GroupCommandController


def _serves_action(controller: Controller) -> bool:
    """Whether the controller is an action server (FollowJointTrajectory, GripperCommand)."""
    return isinstance(controller, JointTrajectoryController | GripperActionController)


def _controller(
    world: World,
    connector: Connector,
    names: RobotNames,
    namespace: str,
    spec: TrajectoryControllerSpec | GripperControllerSpec | GroupControllerSpec,
) -> Controller:
    if isinstance(spec, GripperControllerSpec):
        return GripperActionController(world, connector, names, namespace, spec)
    if isinstance(spec, GroupControllerSpec):
        return GroupCommandController(world, connector, names, namespace, spec)
    return JointTrajectoryController(world, connector, names, namespace, spec)


class RobotBridge:
    """Joint states and commands of one robot with a `ros:` block."""

    def __init__(
        self,
        world: World,
        connector: Connector,
        robot: RobotHandle,
        settings: RosSettings,
        registry: MessageRegistry | None = None,
    ) -> None:
        ros = robot.built.spec.ros
        assert ros is not None, f"robot {robot.name!r} has no ros: block"
        self.world, self.connector, self.ros = world, connector, ros
        self.names = RobotNames(robot, ros.frame_prefix)
        self._registry = registry
        self._stamps = StampMaker(registry or connector.registry)
        self.joints = robot.joint_names
        self.joint_states_topic = resolve_name(ros.namespace, ros.joint_states_topic)
        self.commands = CommandSubscriber(world, connector, settings, robot=self.names)
        self.controllers: dict[str, Controller] = {}
        claimed: dict[str, str] = {}
        for spec in ros.controllers:
            joints = [spec.joint] if isinstance(spec, GripperControllerSpec) else spec.joints
            for joint in joints:
                if joint in claimed:
                    raise SimError(
                        f"robot {robot.name!r}: joint {joint!r} is claimed by controllers "
                        f"{claimed[joint]!r} and {spec.name!r} (as in ros_control, one each)"
                    )
                claimed[joint] = spec.name
            self.controllers[spec.name] = _controller(
                world, connector, self.names, ros.namespace, spec
            )
        self.diff_drive: CmdVelController | None = None
        if ros.diff_drive is not None:
            drive = ros.diff_drive
            self.diff_drive = CmdVelController(
                world,
                connector,
                replace(
                    drive,
                    left_joint=self.names.world_joint(drive.left_joint),
                    right_joint=self.names.world_joint(drive.right_joint),
                    topic=resolve_name(ros.namespace, drive.topic),
                ),
            )
        self._callbacks: list[CallbackHandle] = []
        self._encoder: JointStateEncoder | None = None

    def start(self) -> RobotBridge:
        """Subscribe to the commands and publish joint states at the robot's rate."""
        self.commands.start()
        served = [n for n, c in self.controllers.items() if _serves_action(c)]
        if (
            served
            and self.connector.protocol == "ROS2"
            and ACTION_SERVERS_EXTENSION not in self.connector.extensions
        ):
            _log.warning(
                "robot %r: controllers %s not started: the ROS 2 endpoint cannot host their "
                "action servers (no %r extension; simbridge's --backend ros2 endpoint has it)",
                self.names.robot.name,
                ", ".join(served),
                ACTION_SERVERS_EXTENSION,
            )
            for name in served:
                del self.controllers[name]
        for controller in self.controllers.values():
            controller.start()
        if self.diff_drive is not None:
            self.diff_drive.start()
        self.connector.register_publisher(
            self.joint_states_topic, "sensor_msgs/JointState", queue_size=10
        )
        self._callbacks = [
            self.world.add_step_callback(
                lambda _w: self.publish_joint_states(), 1.0 / self.ros.joint_states_rate
            ),
            # a robot on a connection of its own sends each step's messages at once too
            self.world.add_callback_scope(self.connector.batch()),
        ]
        return self

    def close(self) -> None:
        """Stop publishing and unsubscribe (the connector stays open)."""
        if self._callbacks:
            for callback in self._callbacks:
                callback.remove()
            self._callbacks.clear()
            self.connector.unregister_publisher(self.joint_states_topic)
        for controller in self.controllers.values():
            controller.close()
        if self.diff_drive is not None:
            self.diff_drive.close()
        self.commands.close()

    def publish_joint_states(self) -> None:
        """The robot's 1-DoF joints under their URDF names."""
        registry = self._registry or self.connector.registry
        if self._stamps.registry is not registry:
            self._stamps = StampMaker(registry)
        w, ros_name = self.world, self.names.to_ros
        if self._registry is None:  # the connector's layouts: the precompiled writer
            if self._encoder is None:
                self._encoder = JointStateEncoder(w, self.joints, ros_name.__getitem__)
            fmt: WireFormat = "cdr" if self.connector.wire_format == "cdr" else "ros1"
            wire = (fmt, registry.protocol == "ROS1")
            self.connector.publish(self.joint_states_topic, self._encoder.encode(wire))
            return
        positions = w.joint_positions(self.joints)
        velocities = w.joint_velocities(self.joints)
        efforts = w.joint_efforts(self.joints)
        msg = joint_state_message(
            self._stamps,
            w.time,
            {ros_name[j]: v for j, v in positions.items()},
            {ros_name[j]: v for j, v in velocities.items()},
            {ros_name[j]: v for j, v in efforts.items()},
        )
        self.connector.publish(self.joint_states_topic, msg)
