"""`SceneVectorEnv`: many worlds on one compiled model, their physics stepped in one C call.

Every sub-environment is a `SceneEnv` on a `World.clone()` of the first (one `MjModel`,
one `MjData` each). The physics of every world lives in a row of a persistent
`mujoco.batch.Batch` (its integration state, `mjSTATE_INTEGRATION`: positions,
velocities, controls, warm start, ...): one call runs `frame_skip` `mj_step`s of every
row on the batch's thread pool in C (no GIL, no Python between substeps) and brings the
rows' positions and velocities terms up to date (`mjSTAGE_VEL`, which the next step
continues from at no cost). MuJoCo documents the batch as bit-identical to `mj_step` on
one `MjData` per simulation.

The rest of a step runs on the calling thread. Where the action adapter and the task
have batched forms (`ActionAdapter.apply_many`, `Task.evaluate_many` and
`Task.observe_many` on a `WorldBatch`), it is a few NumPy operations over all the worlds,
and the worlds' own `MjData` is left alone until something reads it (a reset, a render,
`worlds`). Otherwise each world's data is brought up to date and its action applied,
world after world, as a single env does. Either way world i gets its single env's bits.
Autoreset follows Gymnasium's default (next step): the step after an episode ended
resets that world and returns its first observation with reward 0.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from mujoco.batch import Batch
from numpy.typing import NDArray

from simbridge.errors import GymError
from simbridge.gym.batch import STAGE, WorldBatch
from simbridge.gym.env import Observation, SceneEnv
from simbridge.sim.world import World

__all__ = ["EnvFactory", "SceneVectorEnv"]

EnvFactory = Callable[..., SceneEnv]
"""Builds one `SceneEnv`; must accept `world=` (a world to reuse) and `render_mode=`."""

VectorStep = tuple[
    Observation, NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_], dict[str, Any]
]


class SceneVectorEnv(VectorEnv[Observation, NDArray[np.float32], NDArray[Any]]):
    """`num_envs` copies of the environment `make_env(**env_kwargs)` builds, one model.

    `max_episode_steps` truncates episodes (as `TimeLimit` does for one env); `threads`
    is the number of threads stepping the physics (0: one per CPU; the calling thread is
    one of them).
    """

    def __init__(
        self,
        make_env: EnvFactory,
        num_envs: int,
        *,
        max_episode_steps: int | None = None,
        threads: int = 0,
        **env_kwargs: Any,
    ) -> None:
        if num_envs < 1:
            raise GymError(f"num_envs must be >= 1, got {num_envs}")
        if threads < 0:
            raise GymError(f"threads must be >= 0 (0: one per CPU), got {threads}")
        if max_episode_steps is not None and max_episode_steps < 1:
            raise GymError(f"max_episode_steps must be >= 1 or None, got {max_episode_steps}")
        first = make_env(**env_kwargs)
        self._envs = [first] + [
            make_env(world=first.world.clone(), **env_kwargs) for _ in range(num_envs - 1)
        ]
        self.num_envs = num_envs
        self.max_episode_steps = max_episode_steps
        self.render_mode = first.render_mode
        self.metadata = {**first.metadata, "autoreset_mode": AutoresetMode.NEXT_STEP}
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(first.observation_space, num_envs)
        self.action_space = batch_space(first.action_space, num_envs)
        self.model = first.world.model
        self.frame_skip = first.frame_skip
        # built after every env bound its drives: the batch runs on a copy of the model
        threads = max(1, min(threads or os.cpu_count() or 1, num_envs))
        self._batch = Batch(self.model, num_envs, nthread=threads, persistent=True)
        task, action = first.task, first.action
        fields = (*task.batch_fields, *action.batch_fields)
        self._data = WorldBatch(self._batch, [env.world for env in self._envs], fields)
        self._tasks = [env.task for env in self._envs]
        self._evaluate_many = type(task).evaluate_many
        # every part batched: the worlds' data is left alone between resets
        self._batched_action = action.batched
        self._batched = action.batched and task.batched and not first.sensors
        self._stale = np.zeros(num_envs, np.bool_)
        """Worlds whose data lags their row (brought up to date when read: `_sync`)."""
        self._goals = np.zeros((num_envs, *task.goal_space.shape))
        space = first.action_space
        self._action_low, self._action_high = space.low, space.high
        self._elapsed = np.zeros(num_envs, np.int64)
        self._autoreset = np.zeros(num_envs, np.bool_)
        self._everyone = np.ones(num_envs, np.bool_)
        self._everyone.flags.writeable = False
        self._layout = [  # of the observation arrays every step returns afresh
            (key, array.shape, array.dtype)
            for key, array in first.empty_observations(num_envs).items()
        ]

    @property
    def envs(self) -> list[SceneEnv]:
        """The sub-environments, their worlds brought up to date."""
        self._sync(self._stale)
        return list(self._envs)

    @property
    def worlds(self) -> list[World]:
        """The sub-environments' worlds (same model), brought up to date."""
        return [env.world for env in self.envs]

    def _sync(self, which: NDArray[np.bool_]) -> None:
        """Bring the data of the stale worlds among `which` up to date with their rows: the
        state, the drive targets and what a single env's step leaves derived."""
        for i in np.flatnonzero(which & self._stale).tolist():
            self._data.store(i)
            self._envs[i].refresh()
        self._stale &= ~which

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Observation, dict[str, Any]]:
        """Reset every world; an int seed gives world i the seed `seed + i`."""
        if seed is None or isinstance(seed, int):
            seeds: list[int | None] = [
                None if seed is None else seed + i for i in range(self.num_envs)
            ]
        else:
            seeds = list(seed)
        if len(seeds) != self.num_envs:
            raise GymError(f"reset needs {self.num_envs} seeds, got {len(seeds)}")
        success = np.zeros(self.num_envs, np.bool_)
        for i, env_seed in enumerate(seeds):
            success[i] = self._begin(i, env_seed)
        self._data.derive(list(range(self.num_envs)))
        self._stale[:] = False
        observations = {key: np.empty(shape, dtype) for key, shape, dtype in self._layout}
        SceneEnv.observe_many(self._envs, self._tasks, self._data, self._goals, observations)
        self._elapsed[:] = 0
        self._autoreset[:] = False
        return observations, self._info(success)

    def _begin(self, i: int, seed: int | None = None) -> bool:
        """A new episode in world i (its data and its row); whether it is already solved."""
        env = self._envs[i]
        solved = env.begin_episode(seed)
        self._data.load(i)
        self._goals[i] = env.goal
        return solved

    def step(self, actions: NDArray[Any]) -> VectorStep:
        """One step of every world (worlds whose episode ended last step are reset instead)."""
        clipped = self._clip(actions)
        resetting = self._autoreset
        resets = np.flatnonzero(resetting).tolist() if resetting.any() else []
        if self._batched_action:  # every row, the resetting ones' overwritten below
            self._envs[0].action.apply_many(self._data, clipped)
            if not resets:
                self._batch.step(None, nstep=self.frame_skip, stage=STAGE)
            elif len(resets) < self.num_envs:
                stepping = np.flatnonzero(~resetting).astype(np.int32)
                self._batch.step(stepping, nstep=self.frame_skip, stage=STAGE)
        else:
            self._apply_each(clipped, resetting)
        if resets:
            success = np.zeros(self.num_envs, np.bool_)
            for i in resets:
                success[i] = self._begin(i)
            self._data.derive(resets)
        np.logical_not(resetting, out=self._stale)  # stepped: behind; reset: current
        if not self._batched:  # per-world code reads the worlds' data
            self._sync(self._everyone)
        reward, solved, terminated = self._evaluate_many(
            self._tasks, self._data, self._goals, clipped
        )
        if not math.isfinite(float(reward.sum())):
            raise GymError(f"task {type(self._tasks[0]).__name__} returned rewards {reward}")
        observations = {key: np.empty(shape, dtype) for key, shape, dtype in self._layout}
        SceneEnv.observe_many(self._envs, self._tasks, self._data, self._goals, observations)
        elapsed = self._elapsed
        elapsed += 1
        if resets:  # what a reset returns: reward 0, not terminated, its own success
            reward[resetting], terminated[resetting] = 0.0, False
            success[~resetting] = solved[~resetting]
            elapsed[resetting] = 0
        else:
            success = solved
        limit = self.max_episode_steps
        truncated = elapsed >= limit if limit is not None else np.zeros(self.num_envs, np.bool_)
        self._autoreset = terminated | truncated
        return observations, reward, terminated, truncated, self._info(success)

    def _apply_each(self, clipped: NDArray[np.float32], resetting: NDArray[np.bool_]) -> None:
        """Each stepping world's action applied to its own world (brought up to date
        first), its row saved, then the physics: worlds whose drives' ctrl holds over the
        frame skip in one batch call, the others (a ctrl row per substep) a call per
        substep."""
        self._sync(~resetting)
        held: list[int] = []
        varying: dict[int, NDArray[np.float64]] = {}
        for i, (env, action, resets) in enumerate(
            zip(self._envs, clipped, resetting.tolist(), strict=True)
        ):
            if resets:
                continue
            ctrl = env.action.controls(env.world, action, self.frame_skip)
            self._data.save(i)
            if ctrl is None:
                held.append(i)
            else:
                varying[i] = ctrl
        if held:
            ids = None if len(held) == self.num_envs else np.array(held, np.int32)
            self._batch.step(ids, nstep=self.frame_skip, stage=STAGE)
        if varying:
            ids = np.array(list(varying), np.int32)
            rows = np.stack(list(varying.values()))  # (worlds, substeps, nu)
            for substep in range(rows.shape[1]):
                self._data.ctrl[ids] = rows[:, substep]
                self._batch.step(ids, stage=STAGE)

    def _clip(self, actions: NDArray[Any]) -> NDArray[np.float32]:
        """Every world's action at once, as `SceneEnv.clip_action` clips one."""
        array = np.asarray(actions, dtype=np.float32)
        if array.shape != self.action_space.shape:
            raise GymError(
                f"actions must have shape {self.action_space.shape}, got {np.shape(actions)}"
            )
        if not math.isfinite(float(array.sum())):
            raise GymError(f"actions must be finite, got {actions!r}")
        clipped = np.maximum(array, self._action_low)  # a new array: the caller's is kept
        return np.minimum(clipped, self._action_high, out=clipped)

    def _info(self, success: NDArray[np.bool_]) -> dict[str, Any]:
        """Gymnasium's vector info layout (key -> array, "_key" -> mask): every world
        reports "is_success" on every step and reset."""
        return {"is_success": success, "_is_success": self._everyone.copy()}

    def render(self) -> tuple[NDArray[np.uint8], ...] | None:
        """One frame per world when render_mode is "rgb_array"."""
        if self.render_mode != "rgb_array":
            return None
        frames = [env.render() for env in self.envs]
        return tuple(frame for frame in frames if frame is not None)

    def close_extras(self, **kwargs: Any) -> None:
        """Free the worlds' renderers."""
        for env in self._envs:
            env.close()
