"""Connect a `World` to ROS through a `Connector`: state and sensors out, commands in, control
services."""

from __future__ import annotations

from simbridge.connector import Connector
from simbridge.messages import MessageRegistry
from simbridge.sim.ros.cmd_vel_controller import CmdVelController
from simbridge.sim.ros.commands import CommandSubscriber
from simbridge.sim.ros.robot_bridge import RobotBridge
from simbridge.sim.ros.sensor_publisher import SensorPublisher
from simbridge.sim.ros.services import ControlServices
from simbridge.sim.ros.state_publisher import StatePublisher
from simbridge.sim.scene.spec import RosSettings
from simbridge.sim.sensors import SensorSuite
from simbridge.sim.sensors.odometry import Odometry
from simbridge.sim.world.callbacks import CallbackHandle
from simbridge.sim.world.world import World

__all__ = ["SimRosBridge"]


class SimRosBridge:
    """All ROS interfaces of a simulation, as configured by the scene's `ros` section.

    Messages follow the connector's registry (ROS 1 or ROS 2 layouts, as the endpoint's
    handshake says) unless `registry` fixes one.
    """

    def __init__(
        self,
        world: World,
        connector: Connector,
        settings: RosSettings | None = None,
        registry: MessageRegistry | None = None,
        *,
        elsewhere: frozenset[str] = frozenset(),
        sensors: SensorSuite | None = None,
        measure_all: bool = False,
    ) -> None:
        """`elsewhere`: names of namespaced robots served by robot bridges of their own
        (on their own connections); this bridge leaves their joint states and commands
        alone. `sensors`: published on the same connector, their frames on /tf_static;
        `measure_all`: every sensor output measured even without subscribers (recording)."""
        self.world = world
        self.connector = connector
        self.settings = settings or world.scene.ros
        self.registry = registry
        self.state = StatePublisher(world, connector, self.settings, self.registry)
        self.robots = {
            name: RobotBridge(world, connector, robot, self.settings, self.registry)
            for name, robot in world.robots.items()
            if robot.built.spec.ros is not None and name not in elsewhere
        }
        """Robots with their own `ros:` block (namespace, frame prefix, topics)."""
        shared = [
            j
            for name, robot in world.robots.items()
            if robot.built.spec.ros is None
            for j in robot.driven_joints
        ]
        self.commands = (
            CommandSubscriber(world, connector, self.settings, joints=shared)
            if shared or all(r.built.spec.ros is None for r in world.robots.values())
            else None
        )
        """The scene-wide command topics, for robots without a `ros:` block (None when
        every robot has its own)."""
        drive = self.settings.diff_drive
        self.diff_drive = CmdVelController(world, connector, drive) if drive is not None else None
        self.services = ControlServices(
            world, connector, self.settings.services_prefix, self.registry
        )
        self.sensors: SensorPublisher | None = None
        """The sensors' publisher (None without sensors)."""
        if sensors is not None:
            tf = {"/tf"} if self.settings.tf else set()
            self.sensors = SensorPublisher(world, connector, sensors, tf)
            self.sensors.always_on = measure_all
            self.state.extra_static.extend(sensors.static_transforms(world.model))
            # Odometry that broadcasts odom -> base owns the base's parent (REP 105).
            self.state.parented_elsewhere.update(
                s.child_frame_id
                for s in sensors.sensors
                if isinstance(s, Odometry) and s.config.publish_tf
            )
        self._scope: CallbackHandle | None = None

    def start(self) -> SimRosBridge:
        """Register every topic and service; state is published as the world steps, each
        step's messages (state, and sensors on the same connector) sent as one batch."""
        if self._scope is None:
            self._scope = self.world.add_callback_scope(self.connector.batch())
        if self.sensors is not None:
            self.sensors.start()
        self.services.start()
        if self.commands is not None:
            self.commands.start()
        for robot in self.robots.values():
            robot.start()
        if self.diff_drive is not None:
            self.diff_drive.start()
        self.state.start()
        return self

    def close(self) -> None:
        """Unregister everything (the connector stays open)."""
        if self.sensors is not None:
            self.sensors.close()
        if self._scope is not None:
            self._scope.remove()
            self._scope = None
        self.state.close()
        if self.diff_drive is not None:
            self.diff_drive.close()
        for robot in self.robots.values():
            robot.close()
        if self.commands is not None:
            self.commands.close()
        self.services.close()

    def __enter__(self) -> SimRosBridge:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()
