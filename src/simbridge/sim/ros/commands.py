"""Joint commands from ROS: trajectories, group position/velocity commands, joint-state mirror."""

from __future__ import annotations

import logging
from dataclasses import replace
from typing import Any

from simbridge.connector import Connector
from simbridge.errors import SimError
from simbridge.sim.control.drive import DriveMode, DriveSpec
from simbridge.sim.control.follower import TrajectoryFollower
from simbridge.sim.ros.convert import trajectory_from_message
from simbridge.sim.ros.names import RobotNames, resolve_name
from simbridge.sim.scene.spec import CommandTopics, RosSettings
from simbridge.sim.world.callbacks import CallbackHandle
from simbridge.sim.world.world import World

__all__ = ["CommandSubscriber"]

_log = logging.getLogger("simbridge.sim.ros")


class CommandSubscriber:
    """Subscribes to the command topics; each message is applied on the simulation thread.

    Scene-wide (`settings`: trajectories go to the world's own follower), or for one
    namespaced robot (`robot`: its names, namespace and topics; it then drives only that
    robot's joints, with a follower of its own that the world updates beside its own, so
    robots do not cancel each other's trajectories).
    """

    def __init__(
        self,
        world: World,
        connector: Connector,
        settings: RosSettings,
        robot: RobotNames | None = None,
        joints: list[str] | None = None,
    ) -> None:
        """`joints`: the scene-wide group's default (every driven joint when None)."""
        self.world, self.connector, self.settings = world, connector, settings
        self.robot = robot
        self.topics: CommandTopics = settings.commands
        self.namespace = "/"
        self.follower = world.follower
        self._follower_handle: CallbackHandle | None = None
        if robot is not None:
            ros = robot.robot.built.spec.ros
            assert ros is not None
            self.topics, self.namespace = ros.commands, ros.namespace
            driven = robot.robot.driven_joints
            self.group = [robot.world_joint(j) for j in ros.command_joints] or driven
            self.follower = TrajectoryFollower(world.drives)
        else:
            default = world.drives.joints if joints is None else joints
            self.group = list(settings.command_joints) or default
        for joint in self.group:
            world.drives.spec(joint)  # SimError for joints without drives
        self._configured = {j: world.drives.spec(j) for j in world.drives.joints}
        self._topics: list[str] = []
        self.errors: list[str] = []
        """Commands rejected so far (also logged), newest last."""

    def start(self) -> None:
        """Subscribe to every configured command topic."""
        topics = self.topics
        if self.follower is not self.world.follower:
            self._follower_handle = self.world.add_follower(self.follower)
        wanted = [
            (topics.trajectory, "trajectory_msgs/JointTrajectory", self._on_trajectory),
            (topics.position, "std_msgs/Float64MultiArray", self._on_position),
            (topics.velocity, "std_msgs/Float64MultiArray", self._on_velocity),
            (topics.follow_joint_states, "sensor_msgs/JointState", self._on_joint_state),
        ]
        for topic, msg_type, handler in wanted:
            if topic is not None:
                name = resolve_name(self.namespace, topic)
                self.connector.subscribe(name, msg_type, self._posting(handler))
                self._topics.append(name)

    def close(self) -> None:
        """Unsubscribe (and stop a follower of its own)."""
        if self._follower_handle is not None:
            self._follower_handle.remove()
            self._follower_handle = None
        for topic in self._topics:
            self.connector.unsubscribe(topic)
        self._topics.clear()

    def _posting(self, handler: Any) -> Any:
        def receive(msg: Any) -> None:
            def apply() -> None:
                try:
                    handler(msg)
                except SimError as exc:
                    self.errors.append(str(exc))
                    _log.warning("command rejected: %s", exc)

            self.world.post(apply)

        return receive

    def _mode(self, joint: str, mode: DriveMode) -> None:
        spec = self.world.drives.spec(joint)
        if spec.mode is not mode:
            base: DriveSpec = self._configured[joint]
            self.world.drives.set_spec(joint, base.with_changes(mode=mode))

    def _on_trajectory(self, msg: Any) -> None:
        trajectory = trajectory_from_message(msg)
        if trajectory is None:
            self.follower.cancel()
            return
        if self.robot is not None:
            joints = tuple(self.robot.world_joint(j) for j in trajectory.joints)
            trajectory = replace(trajectory, joints=joints)
        for joint in trajectory.joints:
            self.world.drives.spec(joint)
            self._mode(joint, DriveMode.POSITION)
        self.follower.start(trajectory, self.world.time)

    def _group_values(self, msg: Any, what: str) -> list[float]:
        values = [float(v) for v in msg.data]
        if len(values) != len(self.group):
            raise SimError(
                f"{what} command has {len(values)} values for {len(self.group)} joints "
                f"({', '.join(self.group)})"
            )
        return values

    def _on_position(self, msg: Any) -> None:
        values = self._group_values(msg, "position")
        self.follower.cancel()
        for joint, value in zip(self.group, values, strict=True):
            self._mode(joint, DriveMode.POSITION)
            self.world.drives.set_position(joint, value)

    def _on_velocity(self, msg: Any) -> None:
        values = self._group_values(msg, "velocity")
        self.follower.cancel()
        for joint, value in zip(self.group, values, strict=True):
            self._mode(joint, DriveMode.VELOCITY)
            self.world.drives.set_velocity(joint, value)

    def _on_joint_state(self, msg: Any) -> None:
        if self.robot is not None:
            known = self.robot.to_world
        else:
            known = {n: n for n in self.world.joint_names()}
        values = {
            known[str(name)]: float(pos)
            for name, pos in zip(msg.name, msg.position, strict=False)
            if str(name) in known
        }
        self.follower.cancel()
        self.world.set_joint_positions(values)
