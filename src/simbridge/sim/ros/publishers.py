"""Publish the simulation's state: /joint_states, /tf, /tf_static and /clock, in sim time.

Messages take the layouts of the connector's registry unless a registry is given, so
the same scene publishes ROS 1 or ROS 2 messages, whichever the endpoint speaks.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from simbridge.connector import Connector
from simbridge.messages import MessageRegistry, Translator, default_registry
from simbridge.sim.ros.convert import StampMaker, joint_state_message, tf_message
from simbridge.sim.ros.names import RobotNames
from simbridge.sim.scene.model import RosSettings
from simbridge.sim.urdf.transforms import Transform
from simbridge.sim.world.world import World

__all__ = ["StatePublisher"]

WORLD_FRAME = "world"


class StatePublisher:
    """Registers the state topics and publishes them from step callbacks at their rates."""

    def __init__(
        self,
        world: World,
        connector: Connector,
        settings: RosSettings,
        registry: MessageRegistry | None = None,
    ) -> None:
        self.world, self.connector, self.settings = world, connector, settings
        self._registry = registry
        self._stamps = StampMaker(registry or connector.registry)
        self._static_registry: MessageRegistry | None = None
        """The registry /tf_static was last published with (re-sent when it changes)."""
        self._callbacks: list[int] = []
        self._topics: list[str] = []
        self.extra_static: list[Any] = []
        """More geometry_msgs/TransformStamped for /tf_static (e.g. sensor frames), built
        like sensor messages in the ROS 1 layouts of `default_registry()` (translated to
        the registry in use)."""
        self.parented_elsewhere: set[str] = set()
        """Floating-base frames whose parent transform another publisher broadcasts
        (odometry's odom -> base_link): no world -> base edge for them, so TF stays a tree."""
        self.names = {
            name: RobotNames(robot, robot.built.spec.ros.frame_prefix)
            for name, robot in world.robots.items()
            if robot.built.spec.ros is not None
        }
        """Robots with their own `ros:` block: TF frames get their frame prefix, and their
        joints are on their own <ns>/joint_states, not on the scene-wide topic."""
        self.shared_joints = [
            j for name, r in world.robots.items() if name not in self.names for j in r.joint_names
        ]
        """Joints on the scene-wide joint-states topic (robots without a `ros:` block)."""

    def start(self) -> None:
        """Advertise the topics, publish /tf_static once (latched), schedule the rest."""
        s = self.settings
        if s.joint_states_rate > 0 and (self.shared_joints or not self.names):
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

    @property
    def stamps(self) -> StampMaker:
        """Message builder for the registry in use (follows the connector's protocol)."""
        registry = self._registry or self.connector.registry
        if self._stamps.registry is not registry:
            self._stamps = StampMaker(registry)
        return self._stamps

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
        w, joints = self.world, self.shared_joints if self.names else None
        msg = joint_state_message(
            self.stamps,
            w.time,
            w.joint_positions(joints),
            w.joint_velocities(joints),
            w.joint_efforts(joints),
        )
        self.connector.publish(self.settings.joint_states_topic, msg)

    def _edges(self, fixed: bool) -> list[tuple[str, str, Transform]]:
        edges = []
        for name, robot in self.world.robots.items():
            names = self.names.get(name)
            frame = names.frame if names is not None else str
            root = robot.prefix + robot.robot.root
            if (
                frame(root) != WORLD_FRAME
                and robot.built.spec.fixed_base == fixed
                and frame(root) not in self.parented_elsewhere
            ):
                edges.append((WORLD_FRAME, frame(root), self.world.link_pose(root)))
            for parent, child, is_fixed in robot.tree_edges():
                if is_fixed == fixed:
                    relative = self.world.link_pose(parent).inverse() @ self.world.link_pose(child)
                    edges.append((frame(parent), frame(child), relative))
        return edges

    def publish_tf(self) -> None:
        """Transforms across every moving joint (and a floating base)."""
        stamps = self.stamps
        if stamps.registry is not self._static_registry:
            self.publish_tf_static()  # the endpoint's protocol changed: latch it anew
        edges = self._edges(fixed=False)
        if edges:
            self.connector.publish("/tf", tf_message(stamps, self.world.time, edges))

    def publish_tf_static(self) -> None:
        """Transforms across fixed joints and to fixed robot bases (latched)."""
        stamps = self.stamps
        msg = tf_message(stamps, self.world.time, self._edges(fixed=True))
        translator = Translator(default_registry(), stamps.registry)
        msg.transforms.extend(translator.translate(extra) for extra in self.extra_static)
        self._static_registry = stamps.registry
        self.connector.publish("/tf_static", msg)

    def publish_clock(self) -> None:
        """The sim time, so ROS nodes with use_sim_time follow the simulation."""
        msg = self.stamps.cls("rosgraph_msgs/Clock")(clock=self.stamps.time(self.world.time))
        self.connector.publish("/clock", msg)
