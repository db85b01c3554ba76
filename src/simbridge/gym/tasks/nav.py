"""DiffDriveNav-v0: the mobile-robot demo's diff-drive base to a goal in the walled room."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from importlib import resources
from pathlib import Path

import mujoco
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from simbridge.errors import GymError
from simbridge.gym.actions import TwistCommand
from simbridge.gym.env import SceneEnv, look_at
from simbridge.gym.sensors import CameraImage, LidarRanges, SensorObservation
from simbridge.gym.task import Task
from simbridge.sim.control import Pose2D
from simbridge.sim.scene import ObjectSpec, Scene
from simbridge.sim.sensors import Odometry, OdometryConfig
from simbridge.sim.world import World

__all__ = ["NAV_SCENE", "NavTask", "make_nav", "odometry_observation"]

NAV_SCENE = Path(str(resources.files("simbridge") / "apps" / "mobile_robot" / "scene.yaml"))
"""The mobile-robot demo's scene: diffbot in a 4 m x 4 m room, lidar, camera, IMU, odometry."""


def odometry_observation(
    pose: Pose2D, linear: float, angular: float, goal: NDArray[np.float64]
) -> dict[str, NDArray[np.float32]]:
    """The "pose" (x m, y m, cos yaw, sin yaw), "velocity" (m/s, rad/s) and "goal_delta"
    (the goal in the robot's frame: ahead m, left m) entries, from an odometry reading
    here or a nav_msgs/Odometry on the ROS side."""
    dx, dy = float(goal[0]) - pose.x, float(goal[1]) - pose.y
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    return {
        "pose": np.array([pose.x, pose.y, c, s], np.float32),
        "velocity": np.array([linear, angular], np.float32),
        "goal_delta": np.array([c * dx + s * dy, -s * dx + c * dy], np.float32),
    }


def _footprints(scene: Scene) -> list[ObjectSpec]:
    return [o for o in scene.objects if o.shape == "box" and not o.dynamic]


def _clearance(point: NDArray[np.float64], boxes: list[ObjectSpec]) -> float:
    """Distance (m) in the floor plane from `point` to the nearest static box."""
    best = math.inf
    for box in boxes:
        transform = box.pose.transform
        local = transform.rotation.T @ (np.array([point[0], point[1], 0.0]) - transform.translation)
        outside = np.maximum(np.abs(local[:2]) - np.array(box.size[:2]) / 2, 0.0)
        best = min(best, float(np.linalg.norm(outside)))
    return best


class NavTask(Task):
    """Drive the base (origin of `base`) within `tolerance` m of a goal point on the floor.

    Reset: start pose and goal drawn uniformly in the room at least `margin` m from any
    wall or box, at least 1 m apart, random heading. Reward: progress towards the goal
    (m) per step, +1 on arrival, -1 on a collision (the base closer than `radius` to a
    box). Terminates on arrival or collision. Observation adds "pose", "velocity" and
    "goal_delta" (see `odometry_observation`) from the scene's odometry sensor
    (world-anchored, as /odom when the robot starts at the scene's pose).
    """

    goal_space = spaces.Box(-2.0, 2.0, (2,), np.float32)

    def __init__(
        self,
        base: str = "base_link",
        odometry: str = "odom",
        tolerance: float = 0.25,
        radius: float = 0.18,
        margin: float = 0.4,
    ) -> None:
        self.base, self.odometry_name = base, odometry
        self.tolerance, self.radius, self.margin = tolerance, radius, margin
        self._boxes: list[ObjectSpec] = []
        self._free_qpos = -1
        self._odometry: Odometry | None = None
        self._last_distance = 0.0

    def bind(self, world: World) -> None:
        """Find the base's free joint, the obstacles and the odometry sensor."""
        body = world.model.body(self.base)
        joint = int(body.jntadr[0])
        if joint < 0 or world.model.jnt_type[joint] != mujoco.mjtJoint.mjJNT_FREE:
            raise GymError(f"NavTask: body {self.base!r} has no free joint (fixed_base: false?)")
        self._free_qpos = int(world.model.jnt_qposadr[joint])
        self._boxes = _footprints(world.scene)
        entry = next((s for s in world.scene.sensors if s.get("name") == self.odometry_name), None)
        if entry is None:
            raise GymError(f"NavTask: the scene has no odometry sensor {self.odometry_name!r}")
        config = OdometryConfig.from_config(entry)
        self._odometry = Odometry(world.model, dataclasses.replace(config, origin="world"))

    def _free_point(self, rng: np.random.Generator) -> NDArray[np.float64]:
        for _ in range(1000):
            point = rng.uniform(-2.0, 2.0, 2)
            if _clearance(point, self._boxes) >= self.margin:
                return point
        raise GymError("NavTask: no free floor found (is margin larger than the room?)")

    def reset(self, world: World, rng: np.random.Generator) -> NDArray[np.float64]:
        """Teleport the base to a random free pose; draw a free goal 1 m or more away."""
        start = self._free_point(rng)
        goal = self._free_point(rng)
        while np.linalg.norm(goal - start) < 1.0:
            goal = self._free_point(rng)
        yaw = rng.uniform(-math.pi, math.pi)
        adr = self._free_qpos
        world.data.qpos[adr : adr + 2] = start
        world.data.qpos[adr + 3 : adr + 7] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        mujoco.mj_forward(world.model, world.data)
        self._last_distance = float(np.linalg.norm(goal - start))
        return goal

    def _position(self, world: World) -> NDArray[np.float64]:
        return np.asarray(world.data.qpos[self._free_qpos : self._free_qpos + 2], np.float64)

    def observation_spaces(self) -> Mapping[str, spaces.Box]:
        """ "pose" (x, y, cos yaw, sin yaw) and "velocity" (linear m/s, angular rad/s)."""
        return {
            "pose": spaces.Box(-3.0, 3.0, (4,), np.float32),
            "velocity": spaces.Box(-5.0, 5.0, (2,), np.float32),
            "goal_delta": spaces.Box(-6.0, 6.0, (2,), np.float32),
        }

    def observe(self, world: World, goal: NDArray[np.float64]) -> dict[str, NDArray[np.float32]]:
        """Pose and twist as the odometry sensor reads them, and the goal seen from the base."""
        assert self._odometry is not None, "bind() first"
        reading = self._odometry.read(world.model, world.data)
        rotation = reading.pose.rotation
        yaw = math.atan2(rotation[1, 0], rotation[0, 0])
        x, y = (float(v) for v in reading.pose.position[:2])
        linear, angular = float(reading.linear[0]), float(reading.angular[2])
        return odometry_observation(Pose2D(x, y, yaw), linear, angular, goal)

    def collided(self, world: World) -> bool:
        """The base is closer than `radius` to a box (walls included)."""
        return _clearance(self._position(world), self._boxes) < self.radius

    def reward(self, world: World, goal: NDArray[np.float64], action: NDArray[np.float32]) -> float:
        """Progress towards the goal, +1 on arrival, -1 on collision."""
        distance = float(np.linalg.norm(goal - self._position(world)))
        progress, self._last_distance = self._last_distance - distance, distance
        bonus = 1.0 if distance < self.tolerance else (-1.0 if self.collided(world) else 0.0)
        return progress + bonus

    def success(self, world: World, goal: NDArray[np.float64]) -> bool:
        """The base is within tolerance of the goal."""
        return float(np.linalg.norm(goal - self._position(world))) < self.tolerance

    def terminated(self, world: World, goal: NDArray[np.float64]) -> bool:
        """Arrived or collided."""
        return self.success(world, goal) or self.collided(world)


def make_nav(
    *,
    frame_skip: int = 10,
    lidar: bool = True,
    image_size: tuple[int, int] | None = None,
    render_mode: str | None = None,
    world: World | None = None,
    scene: str | Path = NAV_SCENE,
) -> SceneEnv:
    """The DiffDriveNav-v0 environment (`gymnasium.make("simbridge/DiffDriveNav-v0")`).

    Action: Box(2) twist, linear m/s and angular rad/s within the scene's diff_drive
    limits (the demo's: +-0.5 m/s, +-1.5 rad/s), through the /cmd_vel controller.
    Observation: "pose", "velocity", "goal" (x, y m), "lidar" (the scene's `laser`,
    360 ranges, m) and, with `image_size` (height, width), "image" from its `camera`.
    """
    world = world if world is not None else World.from_scene(scene)
    drive = world.scene.ros.diff_drive
    if drive is None:
        raise GymError(f"scene {scene} has no ros.diff_drive section (wheel joints, limits)")
    sensors: list[SensorObservation] = []
    if lidar:
        sensors.append(LidarRanges("laser"))
    if image_size is not None:
        sensors.append(CameraImage("camera", height=image_size[0], width=image_size[1]))
    return SceneEnv(
        scene,
        NavTask(),
        TwistCommand(drive.left_joint, drive.right_joint, drive.limits),
        frame_skip=frame_skip,
        observe_joints=(),
        sensors=sensors,
        render_mode=render_mode,
        render_camera=look_at((0.0, -3.2, 4.2), (0.0, -0.2, 0.0)),
        world=world,
    )
