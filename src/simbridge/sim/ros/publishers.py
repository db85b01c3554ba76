"""Publish the simulation's state: /joint_states, /tf, /tf_static and /clock, in sim time."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from simbridge.connector import Connector
from simbridge.messages import MessageRegistry
from simbridge.sim.ros.convert import StampMaker, joint_state_message, tf_message
from simbridge.sim.scene.model import RosSettings
from simbridge.sim.urdf.transforms import Transform
from simbridge.sim.world.world import World

__all__ = ["StatePublisher"]

WORLD_FRAME = "world"


class StatePublisher:
    """Registers the state topics and publishes them from step callbacks at their rates."""

    def __init__(
        self, world: World, connector: Connector, settings: RosSettings, registry: MessageRegistry
    ) -> None:
        self.world, self.connector, self.settings = world, connector, settings
        self.stamps = StampMaker(registry)
        self._callbacks: list[int] = []
        self._topics: list[str] = []
        self.extra_static: list[Any] = []
        """More geometry_msgs/TransformStamped for /tf_static (e.g. sensor frames)."""
        self.parented_elsewhere: set[str] = set()
        """Floating-base frames whose parent transform another publisher broadcasts
        (odometry's odom -> base_link): no world -> base edge for them, so TF stays a tree."""

    def start(self) -> None:
        """Advertise the topics, publish /tf_static once (latched), schedule the rest."""
        s = self.settings
        if s.joint_states_rate > 0:
            self._advertise(s.joint_states_topic, "sensor_msgs/JointState")
            self._every(1.0 / s.joint_states_rate, self.publish_joint_states)
        if s.tf:
            self._advertise("/tf", "tf2_msgs/TFMessage")
            self._advertise("/tf_static", "tf2_msgs/TFMessage", latch=True)
            self.publish_tf_static()
            self._every(1.0 / s.tf_rate, self.publish_tf)
        if s.clock:
            self._advertise("/clock", "rosgraph_msgs/Clock")
            self._every(1.0 / s.clock_rate, self.publish_clock)

    def close(self) -> None:
        """Stop the callbacks and unadvertise."""
        for cb in self._callbacks:
            self.world.remove_step_callback(cb)
        for topic in self._topics:
            self.connector.unregister_publisher(topic)
        self._callbacks.clear()
        self._topics.clear()

    def _advertise(self, topic: str, msg_type: str, latch: bool = False) -> None:
        self.connector.register_publisher(topic, msg_type, queue_size=10, latch=latch)
        self._topics.append(topic)

    def _every(self, period: float, fn: Callable[[], None]) -> None:
        self._callbacks.append(self.world.add_step_callback(lambda _world: fn(), period))

    def publish_joint_states(self) -> None:
        """Positions, velocities and efforts of every 1-DoF joint."""
        w = self.world
        msg = joint_state_message(
            self.stamps, w.time, w.joint_positions(), w.joint_velocities(), w.joint_efforts()
        )
        self.connector.publish(self.settings.joint_states_topic, msg)

    def _edges(self, fixed: bool) -> list[tuple[str, str, Transform]]:
        edges = []
        for robot in self.world.robots.values():
            root = robot.prefix + robot.robot.root
            if (
                root != WORLD_FRAME
                and robot.built.spec.fixed_base == fixed
                and root not in self.parented_elsewhere
            ):
                edges.append((WORLD_FRAME, root, self.world.link_pose(root)))
            for parent, child, is_fixed in robot.tree_edges():
                if is_fixed == fixed:
                    relative = self.world.link_pose(parent).inverse() @ self.world.link_pose(child)
                    edges.append((parent, child, relative))
        return edges

    def publish_tf(self) -> None:
        """Transforms across every moving joint (and a floating base)."""
        edges = self._edges(fixed=False)
        if edges:
            self.connector.publish("/tf", tf_message(self.stamps, self.world.time, edges))

    def publish_tf_static(self) -> None:
        """Transforms across fixed joints and to fixed robot bases (latched)."""
        msg = tf_message(self.stamps, self.world.time, self._edges(fixed=True))
        msg.transforms.extend(self.extra_static)
        self.connector.publish("/tf_static", msg)

    def publish_clock(self) -> None:
        """The sim time, so ROS nodes with use_sim_time follow the simulation."""
        msg = self.stamps.cls("rosgraph_msgs/Clock")(clock=self.stamps.time(self.world.time))
        self.connector.publish("/clock", msg)
