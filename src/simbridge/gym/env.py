"""`SceneEnv`: a Gymnasium environment from any scene file, a task and an action adapter."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import EllipsisType
from typing import Any

import mujoco
import numpy as np
from gymnasium import Env, spaces
from numpy.typing import NDArray

from simbridge.errors import GymError
from simbridge.gym.actions import ActionAdapter, index_of
from simbridge.gym.batch import WorldBatch
from simbridge.gym.sensors import SensorObservation
from simbridge.gym.task import Task
from simbridge.sim.scene import Scene
from simbridge.sim.sensors import OffscreenRenderer, Pose
from simbridge.sim.world import World

__all__ = ["MAX_JOINT_SPEED", "Observation", "Row", "SceneEnv", "look_at"]

MAX_JOINT_SPEED = 100.0
"""Bound of the "joint_vel" space, rad/s or m/s (drives keep joints far below it)."""

Observation = dict[str, NDArray[Any]]
"""An observation: named arrays (see `SceneEnv.observation_space`)."""
Row = int | EllipsisType
"""Where `observe_into` writes: a row of batched arrays, or `...` for a single observation."""


def look_at(eye: Sequence[float], target: Sequence[float]) -> Pose:
    """A camera pose at `eye` looking at `target` (camera +x forward, +z up)."""
    position = np.asarray(eye, np.float64)
    forward = np.asarray(target, np.float64) - position
    forward /= np.linalg.norm(forward)
    left = np.cross([0.0, 0.0, 1.0], forward)
    left /= np.linalg.norm(left)
    up = np.cross(forward, left)
    return Pose(position, np.column_stack([forward, left, up]))


class SceneEnv(Env[Observation, NDArray[np.float32]]):
    """A MuJoCo world built from a scene, stepped `frame_skip` physics steps per action.

    Observation (a `Dict` space): "joint_pos" (rad or m) and "joint_vel" (rad/s or m/s)
    of `observe_joints` (default: the joints the action drives), the task's own entries,
    "goal", and one entry per sensor. Reward, termination and the reset distribution come
    from `task`; info carries "is_success". Same seed, same episode, bit for bit.
    `render()` (render_mode "rgb_array") draws the scene from `render_camera`.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(
        self,
        scene: Scene | str | Path,
        task: Task,
        action: ActionAdapter,
        *,
        frame_skip: int = 10,
        observe_joints: Sequence[str] | None = None,
        sensors: Sequence[SensorObservation] = (),
        render_mode: str | None = None,
        render_size: tuple[int, int] = (480, 640),
        render_camera: Pose | None = None,
        world: World | None = None,
    ) -> None:
        if frame_skip < 1:
            raise GymError(f"frame_skip must be >= 1 physics step, got {frame_skip}")
        if render_mode not in (None, "rgb_array"):
            raise GymError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.world = world if world is not None else World.from_scene(scene, task.extensions())
        self.task, self.action, self.frame_skip = task, action, frame_skip
        self.sensors = list(sensors)
        self.render_mode = render_mode
        self.render_size = render_size
        self.render_camera = render_camera or look_at((1.0, -1.0, 1.0), (0.0, 0.0, 0.2))
        self.metadata = {**self.metadata, "render_fps": round(1 / self.dt)}
        self.joints = tuple(action.joints if observe_joints is None else observe_joints)
        model = self.world.model
        self._qpos = index_of([int(model.joint(j).qposadr[0]) for j in self.joints])
        self._dofs = index_of([int(model.joint(j).dofadr[0]) for j in self.joints])
        task.bind(self.world)
        action.bind(self.world)
        for sensor in self.sensors:
            sensor.bind(self.world)
        self.action_space: spaces.Box = action.space  # type: ignore[assignment]
        self._action_shape = action.space.shape
        self._action_low, self._action_high = action.space.low, action.space.high
        self.observation_space: spaces.Dict = spaces.Dict(self._spaces())  # type: ignore[assignment]
        self._layout = [
            (key, space.shape or (), np.dtype(space.dtype))
            for key, space in self.observation_space.spaces.items()
        ]
        self._goal = np.zeros(task.goal_space.shape, np.float64)
        self._goal32 = self._goal.astype(np.float32)
        # views on the data's memory, kept: no pybind property lookups on every step
        self._qpos_all, self._qvel_all = self.world.data.qpos, self.world.data.qvel
        self._renderer: OffscreenRenderer | None = None

    @property
    def goal(self) -> NDArray[np.float64]:
        """The episode's goal (the task drew it at reset; the ROS side may set it)."""
        return self._goal

    @goal.setter
    def goal(self, value: NDArray[np.float64]) -> None:
        self._goal = np.asarray(value, np.float64)
        self._goal32 = self._goal.astype(np.float32)

    @property
    def dt(self) -> float:
        """Simulated seconds per env step."""
        return self.frame_skip * self.world.timestep

    def _spaces(self) -> dict[str, spaces.Space[Any]]:
        out: dict[str, spaces.Space[Any]] = {}
        if self.joints:
            model = self.world.model
            low, high = [], []
            for joint in self.joints:
                jnt = model.joint(joint)
                limited = bool(model.jnt_limited[jnt.id])
                low.append(float(jnt.range[0]) - 0.1 if limited else -1e4)
                high.append(float(jnt.range[1]) + 0.1 if limited else 1e4)
            out["joint_pos"] = spaces.Box(
                np.array(low, np.float32), np.array(high, np.float32), dtype=np.float32
            )
            speed = MAX_JOINT_SPEED
            out["joint_vel"] = spaces.Box(-speed, speed, (len(low),), np.float32)
        out.update(self.task.observation_spaces())
        out["goal"] = self.task.goal_space
        for sensor in self.sensors:
            out[sensor.key] = sensor.space
        return out

    # ---- the Gymnasium API -----------------------------------------------------------------

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Observation, dict[str, Any]]:
        """Back to the scene's initial state, then the task draws the episode from the seed."""
        success = self.begin_episode(seed)
        return self.observe(), {"is_success": success}

    def begin_episode(self, seed: int | None = None) -> bool:
        """What `reset` does but observing: the world back to the scene's initial state and a
        new episode drawn (from `seed` if given). Returns whether it is already solved."""
        super().reset(seed=seed)
        world = self.world
        world.reset()
        self.goal = self.task.reset(world, self.np_random)
        world.drives.hold_current()
        self.action.reset(world)
        mujoco.mj_forward(world.model, world.data)
        return self.task.success(world, self.goal)

    def step(
        self, action: NDArray[np.float32]
    ) -> tuple[Observation, float, bool, bool, dict[str, Any]]:
        """Apply `action` (clipped to the action space) for `frame_skip` physics steps."""
        clipped = self.clip_action(action)
        self.simulate(self.action.controls(self.world, clipped, self.frame_skip))
        return self.finish_step(clipped)

    def render(self) -> NDArray[np.uint8] | None:  # type: ignore[override]
        """An (height, width, 3) uint8 frame when render_mode is "rgb_array", else None."""
        if self.render_mode != "rgb_array":
            return None
        if self._renderer is None:
            height, width = self.render_size
            self._renderer = OffscreenRenderer(self.world.model, width, height)
        return self._renderer.render_rgb(self.world.data, self.render_camera, 0.9, 0.01, 50.0)

    def close(self) -> None:
        """Free renderers."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        for sensor in self.sensors:
            sensor.close()

    # ---- the parts of a step (the vector env runs the physics of many at once) -------------

    def clip_action(self, action: NDArray[Any]) -> NDArray[np.float32]:
        """`action` as float32 within the action space; GymError for a wrong shape or NaN."""
        array = np.asarray(action, dtype=np.float32)
        if array.shape != self._action_shape or not math.isfinite(float(array.sum())):
            raise GymError(
                f"action must be a finite array of shape {self._action_shape}, got {action!r}"
            )
        return np.minimum(np.maximum(array, self._action_low), self._action_high)

    def simulate(self, ctrl: NDArray[np.float64] | None) -> None:
        """Run `frame_skip` physics steps with `ctrl` (None: the data's own, or one row per
        step), then `refresh`."""
        model, data = self.world.model, self.world.data
        if ctrl is None:
            mujoco.mj_step(model, data, nstep=self.frame_skip)
        else:
            for row in ctrl:
                data.ctrl[:] = row
                mujoco.mj_step(model, data)
        self.refresh()

    def refresh(self) -> None:
        """Bring poses, Jacobians and body velocities up to date after physics steps
        (`mj_kinematics`, `mj_comPos`, `mj_comVel`) for observing; contacts stay those of
        the last step."""
        model, data = self.world.model, self.world.data
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_comVel(model, data)

    def finish_step(
        self, action: NDArray[np.float32]
    ) -> tuple[Observation, float, bool, bool, dict[str, Any]]:
        """Observation, reward, terminated, truncated (always False: time limits are a
        wrapper's job) and info after the physics ran."""
        reward, success, terminated = self.evaluate(action)
        return self.observe(), reward, terminated, False, {"is_success": success}

    def evaluate(self, action: NDArray[np.float32]) -> tuple[float, bool, bool]:
        """(reward, success, terminated) for the step `action` just took (`Task.evaluate`);
        GymError for a reward that is not finite."""
        reward, success, terminated = self.task.evaluate(self.world, self._goal, action)
        if not math.isfinite(reward):
            raise GymError(f"task {type(self.task).__name__} returned reward {reward}")
        return reward, success, terminated

    def empty_observations(self, count: int | None = None) -> Observation:
        """Uninitialised arrays for `count` observations, one row each, or for one
        observation when `count` is None (to fill with `observe_into`)."""
        if count is None:
            return {key: np.empty(shape, dtype) for key, shape, dtype in self._layout}
        return {key: np.empty((count, *shape), dtype) for key, shape, dtype in self._layout}

    def observe(self, readings: Mapping[str, NDArray[Any]] | None = None) -> Observation:
        """The observation for the world's current state; `readings` replace sensor entries
        by key (the ROS side passes the ranges and images it received)."""
        out = self.empty_observations()
        self.observe_into(out, ..., readings)
        return out

    @staticmethod
    def observe_many(
        envs: Sequence[SceneEnv],
        tasks: Sequence[Task],
        batch: WorldBatch,
        goals: NDArray[np.float64],
        out: Observation,
    ) -> None:
        """`observe_into` of every world of a vector env (envs made by one factory, with
        their `tasks`, world i in row i of `batch` and of `out`), with NumPy over all rows
        where `observe_into` works on one; every row gets the bits `observe_into` gives it
        (the same casts and elementwise operations). Sensors read each world (their data
        must be current)."""
        first = envs[0]
        if first.joints:
            out["joint_pos"][...] = batch.qpos[:, first._qpos]
            out["joint_vel"][...] = batch.qvel[:, first._dofs]
        type(first.task).observe_many(tasks, batch, goals, out)
        out["goal"][...] = goals
        if first.sensors:
            for row, env in enumerate(envs):
                for sensor in env.sensors:
                    out[sensor.key][row] = sensor.read(env.world)

    def observe_into(
        self, out: Observation, row: Row, readings: Mapping[str, NDArray[Any]] | None = None
    ) -> None:
        """Write the observation into row `row` of the arrays in `out` (from
        `empty_observations`; `...`: the whole arrays, one observation). The vector env
        fills its batch this way, with no dict or array per world; `observe` uses it too."""
        if self.joints:
            out["joint_pos"][row] = self._qpos_all[self._qpos]
            out["joint_vel"][row] = self._qvel_all[self._dofs]
        self.task.observe_into(self.world, self._goal, out, row)
        out["goal"][row] = self._goal32
        for sensor in self.sensors:
            reading = None if readings is None else readings.get(sensor.key)
            out[sensor.key][row] = sensor.read(self.world) if reading is None else reading
