"""Reach-v0: the Niryo One's tool_link to a random point in front of it."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from types import EllipsisType
from typing import Any

import mujoco
import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from simbridge.errors import GymError
from simbridge.gym.actions import ActionAdapter, EndEffectorDelta, JointDelta
from simbridge.gym.batch import WorldBatch
from simbridge.gym.env import SceneEnv, look_at
from simbridge.gym.sensors import CameraImage, SensorObservation
from simbridge.gym.task import Task
from simbridge.sim.sensors import CameraConfig
from simbridge.sim.urdf.document import MjcfDocument, fmt
from simbridge.sim.world import ModelExtension, World

__all__ = ["ARM_JOINTS", "REACH_SCENE", "ReachTask", "make_reach", "view_camera"]

REACH_SCENE = Path(str(resources.files("simbridge.gym") / "scenes" / "reach.yaml"))
"""The scene: a Niryo One on the floor, with ROS position commands on its six arm joints."""
ARM_JOINTS = tuple(f"joint_{i}" for i in range(1, 7))
GOAL_MARKER = "goal_marker"


def view_camera(
    eye: Sequence[float], target: Sequence[float], width: int, height: int
) -> CameraConfig:
    """A fixed world camera at `eye` looking at `target` (for image observations)."""
    dx, dy, dz = (t - e for t, e in zip(target, eye, strict=True))
    pitch = math.atan2(-dz, math.hypot(dx, dy))
    rpy = (0.0, pitch, math.atan2(dy, dx))
    xyz = (float(eye[0]), float(eye[1]), float(eye[2]))
    return CameraConfig(
        name="view", body="world", xyz=xyz, rpy=rpy, width=width, height=height, fovy=0.9
    )


def _goal_marker(doc: MjcfDocument) -> None:
    """A mocap body with a small non-colliding sphere, moved to the goal each episode."""
    body = ET.SubElement(doc.worldbody, "body", name=GOAL_MARKER, mocap="true")
    ET.SubElement(
        body,
        "geom",
        type="sphere",
        size=fmt((0.015,)),
        rgba="0.2 0.9 0.3 0.7",
        contype="0",
        conaffinity="0",
        group="1",
    )


class ReachTask(Task):
    """Bring `end_effector`'s origin within `tolerance` m of a random goal.

    Reset: arm joints at the scene's initial positions plus uniform noise of
    +-`joint_noise` rad; goal drawn uniformly at 0.15-0.32 m from the base axis, within
    +-60 degrees of +x, 0.08-0.35 m high. Reward: minus the distance (m). Success (and
    termination): distance < tolerance. Observation adds "ee_pos" and "goal_delta" (goal
    minus ee_pos), m, world frame.
    """

    goal_space = spaces.Box(-1.0, 1.0, (3,), np.float32)
    batched = True
    batch_fields = ("xpos",)

    def __init__(
        self,
        end_effector: str = "tool_link",
        joints: Sequence[str] = ARM_JOINTS,
        tolerance: float = 0.02,
        joint_noise: float = 0.1,
    ) -> None:
        self.end_effector, self.joints = end_effector, tuple(joints)
        self.tolerance, self.joint_noise = tolerance, joint_noise
        self._body = -1
        self._mocap = -1
        self._ee_data: mujoco.MjData | None = None
        self._ee = np.zeros(3)

    def extensions(self) -> Sequence[ModelExtension]:
        """Adds the goal marker."""
        return (_goal_marker,)

    def bind(self, world: World) -> None:
        """Find the end effector and the goal marker."""
        self._body = int(world.model.body(self.end_effector).id)
        self._ee_data, self._ee = world.data, world.data.xpos[self._body]  # a view, kept
        marker = mujoco.mj_name2id(world.model, mujoco.mjtObj.mjOBJ_BODY, GOAL_MARKER)
        self._mocap = int(world.model.body_mocapid[marker]) if marker >= 0 else -1

    def reset(self, world: World, rng: np.random.Generator) -> NDArray[np.float64]:
        """Jitter the arm, draw a goal, move the marker there."""
        start = world.joint_positions(list(self.joints))
        noise = rng.uniform(-self.joint_noise, self.joint_noise, len(self.joints))
        world.set_joint_positions(
            {j: start[j] + float(n) for j, n in zip(self.joints, noise, strict=True)}
        )
        radius = rng.uniform(0.15, 0.32)
        bearing = rng.uniform(-math.pi / 3, math.pi / 3)
        goal = np.array(
            [radius * math.cos(bearing), radius * math.sin(bearing), rng.uniform(0.08, 0.35)]
        )
        if self._mocap >= 0:
            world.data.mocap_pos[self._mocap] = goal
        return goal

    def observation_spaces(self) -> Mapping[str, spaces.Box]:
        """ "ee_pos": the end effector's position, "goal_delta": goal - ee_pos (m, world)."""
        return {
            "ee_pos": spaces.Box(-2.0, 2.0, (3,), np.float32),
            "goal_delta": spaces.Box(-4.0, 4.0, (3,), np.float32),
        }

    def observe(self, world: World, goal: NDArray[np.float64]) -> dict[str, NDArray[np.float32]]:
        """The end effector's position and the goal relative to it."""
        out = {"ee_pos": np.empty(3, np.float32), "goal_delta": np.empty(3, np.float32)}
        self.observe_into(world, goal, out, ...)
        return out

    def observe_into(
        self,
        world: World,
        goal: NDArray[np.float64],
        out: Mapping[str, NDArray[np.float32]],
        row: int | EllipsisType,
    ) -> None:
        """`observe`, written straight into row `row` of `out`."""
        ee = self._ee if self._ee_data is world.data else world.data.xpos[self._body]
        out["ee_pos"][row] = ee
        np.subtract(goal, ee, out=out["goal_delta"][row], casting="same_kind")

    @classmethod
    def observe_many(
        cls,
        tasks: Sequence[Task],
        batch: WorldBatch,
        goals: NDArray[np.float64],
        out: Mapping[str, NDArray[np.float32]],
    ) -> None:
        """`observe_into` of every world at once (the same casts and subtraction)."""
        ee = batch["xpos"][:, _first(tasks)._body]
        out["ee_pos"][...] = ee
        np.subtract(goals, ee, out=out["goal_delta"], casting="same_kind")

    @classmethod
    def evaluate_many(
        cls,
        tasks: Sequence[Task],
        batch: WorldBatch,
        goals: NDArray[np.float64],
        actions: NDArray[np.float32],
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_]]:
        """`evaluate` of every world at once: the distance summed in `distance`'s order."""
        first = _first(tasks)
        delta = batch["xpos"][:, first._body] - goals
        squares = delta * delta
        distance = np.sqrt((squares[:, 0] + squares[:, 1]) + squares[:, 2])
        reached = distance < first.tolerance
        return -distance, reached, reached.copy()

    def distance(self, world: World, goal: NDArray[np.float64]) -> float:
        """End effector to goal (m)."""
        ee = self._ee if self._ee_data is world.data else world.data.xpos[self._body]
        x, y, z = (ee - goal).tolist()
        return math.sqrt(x * x + y * y + z * z)

    def evaluate(
        self, world: World, goal: NDArray[np.float64], action: NDArray[np.float32]
    ) -> tuple[float, bool, bool]:
        """Minus the distance, and success = termination = within tolerance (one distance)."""
        distance = self.distance(world, goal)
        return -distance, distance < self.tolerance, distance < self.tolerance

    def reward(self, world: World, goal: NDArray[np.float64], action: NDArray[np.float32]) -> float:
        """Minus the distance to the goal."""
        return -self.distance(world, goal)

    def success(self, world: World, goal: NDArray[np.float64]) -> bool:
        """Within tolerance."""
        return self.distance(world, goal) < self.tolerance


def _first(tasks: Sequence[Task]) -> ReachTask:
    """The first of a vector env's tasks, which stands for all (one factory, one model)."""
    first = tasks[0]
    assert isinstance(first, ReachTask)
    return first


def make_reach(
    *,
    action: str = "ee_delta",
    frame_skip: int = 10,
    image_size: tuple[int, int] | None = None,
    render_mode: str | None = None,
    world: World | None = None,
    **task_options: Any,
) -> SceneEnv:
    """The Reach-v0 environment (`gymnasium.make("simbridge/Reach-v0", ...)`).

    `action`: "ee_delta" (tool_link steps, m, +-0.02 per axis, Box(3)) or "joint_delta"
    (arm joint target steps, rad, +-0.05, Box(6)). `image_size` (height, width) adds an
    "image" observation from a fixed camera. `task_options` go to `ReachTask`.
    """
    task = ReachTask(**task_options)
    adapter: ActionAdapter
    if action == "ee_delta":
        adapter = EndEffectorDelta(task.end_effector, task.joints, 0.02)
    elif action == "joint_delta":
        adapter = JointDelta(task.joints, 0.05)
    else:
        raise GymError(f"Reach action must be 'ee_delta' or 'joint_delta', got {action!r}")
    sensors: list[SensorObservation] = []
    if image_size is not None:
        height, width = image_size
        camera = view_camera((0.75, -0.55, 0.6), (0.15, 0.0, 0.2), width, height)
        sensors.append(CameraImage(camera))
    return SceneEnv(
        REACH_SCENE,
        task,
        adapter,
        frame_skip=frame_skip,
        sensors=sensors,
        render_mode=render_mode,
        render_camera=look_at((0.75, -0.55, 0.6), (0.15, 0.0, 0.2)),
        world=world,
    )
