"""Run a policy trained in a `SceneEnv` unchanged against the ROS-connected simulation.

`RosPolicyRunner` is a policy node: a connector client of the endpoint (on the local bus,
or on ROS 1 through `simbridge endpoint --backend ros1`) next to `simbridge sim SCENE`.
The env the policy was trained in serves as a kinematic mirror of the simulated robot:
its joints follow `/joint_states` (an arm) or its base follows the odometry topic (a
mobile base), so the task's own observation code runs unchanged, and sensor entries come
from the sensor topics (`/scan`, `image_raw`), which the same sensor classes publish. The
action goes through the env's own `ActionAdapter` on the mirror, and what it commands is
published: the joint drives' position targets on the scene's position-command topic,
or the twist on the diff-drive topic. One control step per state message: the scene's
`joint_states_rate` (or the odometry rate) is the policy's rate, as `frame_skip` is in
the env.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from simbridge.connector import Connector
from simbridge.errors import GymError, SimbridgeError
from simbridge.gym.actions import (
    ActionAdapter,
    CombinedAction,
    EndEffectorDelta,
    GripperCommand,
    JointDelta,
    TwistCommand,
)
from simbridge.gym.env import Observation, SceneEnv
from simbridge.gym.sensors import CameraImage, LidarRanges, finite_ranges
from simbridge.messages import default_registry

__all__ = ["Policy", "RosPolicyRunner"]

Policy = Callable[[Observation], NDArray[Any]]
"""Observation in, action out (e.g. an `ARSResult.policy`)."""

_log = logging.getLogger("simbridge.gym")
_JOINT_ADAPTERS = (JointDelta, EndEffectorDelta, GripperCommand)


def _parts(adapter: ActionAdapter) -> list[ActionAdapter]:
    if isinstance(adapter, CombinedAction):
        return [p for part in adapter.parts for p in _parts(part)]
    return [adapter]


class RosPolicyRunner:
    """Drives the ROS-side robot with `policy`, seeing what `env` would show it.

    `goal` is the episode's goal (a point of the task's goal space). `steps` counts the
    control steps taken; `last_observation` and `last_action` are the latest; `errors`
    collects failures (also logged) instead of raising on the connector's thread.
    """

    def __init__(
        self, env: SceneEnv, policy: Policy, connector: Connector, goal: ArrayLike
    ) -> None:
        self.env, self.policy, self.connector = env, policy, connector
        self.world = env.world
        self.ros = self.world.scene.ros
        self.registry = default_registry()
        env.goal = np.asarray(goal, np.float64).reshape(env.task.goal_space.shape)
        parts = _parts(env.action)
        self.twist = env.action if isinstance(env.action, TwistCommand) else None
        if self.twist is None and not all(isinstance(p, _JOINT_ADAPTERS) for p in parts):
            kinds = [type(p).__name__ for p in parts]
            raise GymError(f"no ROS command interface for actions {kinds}")
        self.steps = 0
        self.last_observation: Observation | None = None
        self.last_action: NDArray[np.float32] | None = None
        self.errors: list[str] = []
        self._readings: dict[str, NDArray[Any]] = {}
        self._started = False
        self._lock = threading.Lock()
        self._stepping = threading.Lock()
        """Held by a control step and by `close`, so no step publishes once closed."""
        self._closed = False
        self._slots = {
            name: (slot.qpos, slot.dof)
            for robot in self.world.robots.values()
            for name, slot in robot.joints.items()
        }
        if self.twist is None:
            if self.ros.commands.position is None:
                raise GymError("the scene has no ros.commands.position topic for the arm")
            self.command_topic = self.ros.commands.position
            self.command_joints = list(self.ros.command_joints) or self.world.drives.joints
            self.state_topic = self.ros.joint_states_topic
        else:
            if self.ros.diff_drive is None:
                raise GymError("the scene has no ros.diff_drive section for the twist")
            self.command_topic = self.ros.diff_drive.topic
            odometry = next((s for s in self.world.scene.sensors if s["type"] == "odometry"), None)
            if odometry is None:
                raise GymError("a mobile base needs an odometry sensor in the scene")
            self.state_topic = odometry.get("topic") or "odom"
            base = self.world.model.body(odometry["body"])
            joint = int(base.jntadr[0])
            if joint < 0 or self.world.model.jnt_type[joint] != mujoco.mjtJoint.mjJNT_FREE:
                raise GymError(f"odometry body {odometry['body']!r} has no free joint")
            self._free = (int(self.world.model.jnt_qposadr[joint]), int(base.dofadr[0]))

    def start(self) -> RosPolicyRunner:
        """Subscribe to the state and sensor topics and advertise the command topic."""
        if self.twist is None:
            self.connector.register_publisher(self.command_topic, "std_msgs/Float64MultiArray")
            self.connector.subscribe(self.state_topic, "sensor_msgs/JointState", self._on_joints)
        else:
            self.connector.register_publisher(self.command_topic, "geometry_msgs/Twist")
            self.connector.subscribe(self.state_topic, "nav_msgs/Odometry", self._on_odometry)
        for sensor in self.env.sensors:
            if isinstance(sensor, LidarRanges):
                assert sensor.lidar is not None
                self.connector.subscribe(
                    sensor.lidar.topic, "sensor_msgs/LaserScan", self._lidar_reader(sensor)
                )
            elif isinstance(sensor, CameraImage):
                assert sensor.camera is not None
                self.connector.subscribe(
                    sensor.camera.image_topic, "sensor_msgs/Image", self._image_reader(sensor)
                )
        return self

    def close(self) -> None:
        """Unsubscribe and stop publishing (a control step running now finishes first)."""
        with self._stepping:
            self._closed = True
        self.connector.unsubscribe(self.state_topic)
        for sensor in self.env.sensors:
            if isinstance(sensor, LidarRanges) and sensor.lidar is not None:
                self.connector.unsubscribe(sensor.lidar.topic)
            elif isinstance(sensor, CameraImage) and sensor.camera is not None:
                self.connector.unsubscribe(sensor.camera.image_topic)
        self.connector.unregister_publisher(self.command_topic)

    def __enter__(self) -> RosPolicyRunner:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ---- sensor topics ---------------------------------------------------------------------

    def _lidar_reader(self, sensor: LidarRanges) -> Callable[[Any], None]:
        assert sensor.lidar is not None
        config = sensor.lidar.config

        def read(msg: Any) -> None:
            ranges = finite_ranges(np.asarray(msg.ranges), config.range_min, config.range_max)
            if ranges.shape != sensor.space.shape:
                self._fail(f"{ranges.shape[0]} lidar ranges, the env expects {sensor.space.shape}")
                return
            with self._lock:
                self._readings[sensor.key] = ranges

        return read

    def _image_reader(self, sensor: CameraImage) -> Callable[[Any], None]:
        def read(msg: Any) -> None:
            shape = (int(msg.height), int(msg.width), 3)
            if shape != sensor.space.shape or msg.encoding != "rgb8":
                self._fail(
                    f"image {shape} {msg.encoding}; the env expects {sensor.space.shape} rgb8 "
                    "(give the env the scene camera's size)"
                )
                return
            image = np.frombuffer(bytes(msg.data), np.uint8).reshape(shape)
            with self._lock:
                self._readings[sensor.key] = image

        return read

    # ---- state topics: mirror, observe, act, publish -----------------------------------------

    def _on_joints(self, msg: Any) -> None:
        data = self.world.data
        velocities = list(msg.velocity)
        for index, name in enumerate(msg.name):
            slot = self._slots.get(str(name))
            if slot is not None:
                data.qpos[slot[0]] = float(msg.position[index])
                if index < len(velocities):
                    data.qvel[slot[1]] = float(velocities[index])
        self._control()

    def _on_odometry(self, msg: Any) -> None:
        data = self.world.data
        qpos, dof = self._free
        pose, twist = msg.pose.pose, msg.twist.twist
        q = pose.orientation
        data.qpos[qpos : qpos + 3] = (pose.position.x, pose.position.y, pose.position.z)
        data.qpos[qpos + 3 : qpos + 7] = (q.w, q.x, q.y, q.z)
        mujoco.mj_kinematics(self.world.model, data)
        rotation = data.xmat[self.world.model.dof_bodyid[dof]].reshape(3, 3)
        linear = np.array([twist.linear.x, twist.linear.y, twist.linear.z])
        data.qvel[dof : dof + 3] = rotation @ linear  # a free joint's linear velocity: world
        data.qvel[dof + 3 : dof + 6] = (twist.angular.x, twist.angular.y, twist.angular.z)
        self._control()

    def _control(self) -> None:
        with self._stepping:
            if not self._closed:
                self._control_step()

    def _control_step(self) -> None:
        world = self.world
        model, data = world.model, world.data
        try:
            mujoco.mj_kinematics(model, data)
            mujoco.mj_comPos(model, data)
            mujoco.mj_comVel(model, data)
            if not self._started:
                world.drives.hold_current()  # as the env's reset: targets where the joints are
                self.env.action.reset(world)
                self._started = True
            with self._lock:
                readings = dict(self._readings)
            missing = [s.key for s in self.env.sensors if s.key not in readings]
            if missing:
                return  # wait for the first message of every sensor
            obs = self.env.observe(readings)
            action = self.env.clip_action(self.policy(obs))
            self.env.action.apply(world, action)
            self._publish(action)
        except SimbridgeError as exc:
            self._fail(str(exc))
            return
        self.last_observation, self.last_action = obs, action
        self.steps += 1

    def _publish(self, action: NDArray[np.float32]) -> None:
        if self.twist is not None:
            msg = self.registry.new("geometry_msgs/Twist")
            msg.linear.x, msg.angular.z = float(action[0]), float(action[1])
        else:
            targets = [self.world.drives.target(j).position for j in self.command_joints]
            msg = self.registry.new("std_msgs/Float64MultiArray", data=np.array(targets))
        self.connector.publish(self.command_topic, msg)

    def _fail(self, text: str) -> None:
        self.errors.append(text)
        _log.warning("policy runner: %s", text)
