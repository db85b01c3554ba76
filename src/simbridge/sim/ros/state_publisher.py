"""Publish the simulation's state: /joint_states, /tf, /tf_static and /clock, in sim time.

Messages take the layouts of the connector's registry unless a registry is given, so
the same scene publishes ROS 1 or ROS 2 messages, whichever the endpoint speaks. With
the connector's layouts, the periodic topics skip message objects: precompiled writers
(`simbridge.messages.fastwire`) lay out each payload once and only stamp it and write
the numbers (read straight from MuJoCo's arrays) on every publish.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from simbridge.connector import Connector, Publisher
from simbridge.messages import MessageRegistry, Translator, WireFormat, default_registry
from simbridge.messages.fastwire import ClockWriter, TFWriter
from simbridge.sim.ros.convert import StampMaker, joint_state_message, tf_message
from simbridge.sim.ros.joint_state_encoder import JointStateEncoder, stamp_parts
from simbridge.sim.ros.names import RobotNames
from simbridge.sim.scene.spec import RosSettings
from simbridge.sim.urdf.transforms import Transform
from simbridge.sim.world.callbacks import CallbackHandle
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
        self._callbacks: list[CallbackHandle] = []
        self._topics: list[str] = []
        self._pubs: dict[str, Publisher] = {}
        self._wire_cache: tuple[object, str, tuple[WireFormat, bool]] | None = None
        """(connector registry, protocol, wire) of the last `_wire()` answer."""
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
        self._js_encoder: JointStateEncoder | None = None
        self._tf_writer: TFWriter | None = None
        self._tf_bodies: list[tuple[int, int]] = []
        """MuJoCo body ids of the moving edges' parents and children (for `_tf_writer`)."""
        self._tf_elsewhere: tuple[str, ...] = ()
        """`parented_elsewhere` when `_tf_writer` was laid out (its edges depend on it)."""
        self._clock_writer: ClockWriter | None = None

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
    def topics(self) -> tuple[str, ...]:
        """The topics advertised (by `start`, until `close`)."""
        return tuple(self._topics)

    @property
    def stamps(self) -> StampMaker:
        """Message builder for the registry in use (follows the connector's protocol)."""
        registry = self._registry or self.connector.registry
        if self._stamps.registry is not registry:
            self._stamps = StampMaker(registry)
        return self._stamps

    def close(self) -> None:
        """Stop the callbacks and unadvertise."""
        for callback in self._callbacks:
            callback.remove()
        for topic in self._topics:
            self.connector.unregister_publisher(topic)
        self._callbacks.clear()
        self._topics.clear()
        self._pubs.clear()

    def _advertise(self, topic: str, msg_type: str, latch: bool = False) -> None:
        pub = self.connector.register_publisher(topic, msg_type, queue_size=10, latch=latch)
        self._pubs[topic] = pub
        self._topics.append(topic)

    def _every(self, period: float, fn: Callable[[], None]) -> None:
        self._callbacks.append(self.world.add_step_callback(lambda _world: fn(), period))

    def publish_joint_states(self) -> None:
        """Positions, velocities and efforts of every 1-DoF joint."""
        w, joints = self.world, self.shared_joints if self.names else None
        wire = self._wire()
        if wire is not None:
            if self._js_encoder is None:
                self._js_encoder = JointStateEncoder(w, joints)
            self._pubs[self.settings.joint_states_topic].publish(self._js_encoder.encode(wire))
            return
        positions = w.joint_positions(joints)
        velocities, efforts = w.joint_velocities(joints), w.joint_efforts(joints)
        msg = joint_state_message(self.stamps, w.time, positions, velocities, efforts)
        self.connector.publish(self.settings.joint_states_topic, msg)

    def _wire(self) -> tuple[WireFormat, bool] | None:
        """(wire format, Header has seq) for the precompiled writers; None when messages
        must be built as objects (a registry was given, whose layouts the writers do not
        follow). Worked out again only when the connector's protocol or registry changed."""
        if self._registry is not None:
            return None
        connector = self.connector
        registry, protocol = connector.registry, connector.protocol
        cached = self._wire_cache
        if cached is not None and cached[0] is registry and cached[1] == protocol:
            return cached[2]
        wire: tuple[WireFormat, bool] = (
            "cdr" if protocol == "ROS2" else "ros1",
            registry.protocol == "ROS1",
        )
        self._wire_cache = (registry, protocol, wire)
        return wire

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
        wire = self._wire()
        if wire is None:
            edges = self._edges(fixed=False)
            if edges:
                self.connector.publish("/tf", tf_message(stamps, self.world.time, edges))
            return
        writer, bodies = self._tf_writer, self._tf_bodies
        elsewhere = tuple(sorted(self.parented_elsewhere))
        if writer is None or writer.wire != wire or self._tf_elsewhere != elsewhere:
            frames = self._edge_frames(fixed=False)
            pairs = tuple((parent, child) for parent, child, _, _ in frames)
            body = self._body_id
            self._tf_bodies = bodies = [
                (body(parent), body(child)) for _, _, parent, child in frames
            ]
            writer = self._tf_writer = TFWriter(wire[0], pairs, seq=wire[1])
            self._tf_elsewhere = elsewhere
        if bodies:
            self.world.refresh_state()
            poses = relative_poses(self.world.data, bodies)
            self._pubs["/tf"].publish(writer.encode(*stamp_parts(self.world.time), poses))

    def _body_id(self, link: str) -> int:
        return 0 if link == WORLD_FRAME else int(self.world.model.body(link).id)

    def _edge_frames(self, fixed: bool) -> list[tuple[str, str, str, str]]:
        """(parent frame, child frame, parent link, child link) of the TF edges."""
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
                edges.append((WORLD_FRAME, frame(root), WORLD_FRAME, root))
            for parent, child, is_fixed in robot.tree_edges():
                if is_fixed == fixed:
                    edges.append((frame(parent), frame(child), parent, child))
        return edges

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
        wire = self._wire()
        if wire is None:
            msg = self.stamps.cls("rosgraph_msgs/Clock")(clock=self.stamps.time(self.world.time))
            self.connector.publish("/clock", msg)
            return
        writer = self._clock_writer
        if writer is None or writer.fmt != wire[0]:
            writer = self._clock_writer = ClockWriter(wire[0])
        self._pubs["/clock"].publish(writer.encode(*stamp_parts(self.world.time)))


def relative_poses(data: Any, edges: Sequence[tuple[int, int]]) -> list[tuple[float, ...]]:
    """(x, y, z, qx, qy, qz, qw) of each (parent, child) body pair's child in the parent's
    frame, from MuJoCo's world poses (`data.xpos`, `xmat`, `xquat`; body 0 is the world),
    with the quaternion's w >= 0 as `Transform.quat_xyzw` gives it. Plain floats: for a
    handful of edges this beats numpy's per-call overhead several times over."""
    xpos, xmat, xquat = data.xpos.tolist(), data.xmat.tolist(), data.xquat.tolist()
    out: list[tuple[float, ...]] = []
    for parent, child in edges:
        (px, py, pz), (cx, cy, cz) = xpos[parent], xpos[child]
        dx, dy, dz = cx - px, cy - py, cz - pz
        m0, m1, m2, m3, m4, m5, m6, m7, m8 = xmat[parent]
        aw, ax, ay, az = xquat[parent]
        bw, bx, by, bz = xquat[child]
        # conj(parent) * child, Hamilton product
        qw = aw * bw + ax * bx + ay * by + az * bz
        qx = aw * bx - ax * bw - ay * bz + az * by
        qy = aw * by + ax * bz - ay * bw - az * bx
        qz = aw * bz - ax * by + ay * bx - az * bw
        if qw < 0:
            qx, qy, qz, qw = -qx, -qy, -qz, -qw
        out.append(
            (
                m0 * dx + m3 * dy + m6 * dz,  # the parent's rotation transposed, applied
                m1 * dx + m4 * dy + m7 * dz,
                m2 * dx + m5 * dy + m8 * dz,
                qx,
                qy,
                qz,
                qw,
            )
        )
    return out
