"""`SceneVectorEnv`: many worlds on one compiled model, their physics stepped in one C call.

Every sub-environment is a `SceneEnv` on a `World.clone()` of the first (one `MjModel`,
one `MjData` each): resets, drive targets, observations and rewards run there, in
Python, one world after another. The physics of a vector step is one call of MuJoCo's
`mujoco.batch.Batch`: each world's integration state (`mjSTATE_INTEGRATION`: positions,
velocities, controls, warm start, ...) goes into a row, the batch runs `frame_skip`
`mj_step`s of every row on its thread pool in C (no GIL, no Python between substeps),
and the rows come back into the worlds' data, which `SceneEnv.refresh` brings up to date.
MuJoCo documents the batch as bit-identical to `mj_step` on one `MjData` per simulation,
so a sub-environment matches its single-env twin bit for bit. Autoreset follows
Gymnasium's default (next step): the step after an episode ended resets that world and
returns its first observation with reward 0.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from mujoco.batch import Batch
from numpy.typing import NDArray

from simbridge.errors import GymError
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
        first = make_env(**env_kwargs)
        self.envs = [first] + [
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
        self._batch = Batch(self.model, num_envs, nthread=threads)
        self._spec = int(mujoco.mjtState.mjSTATE_INTEGRATION)
        self._state = self._batch.state
        self._rows = list(self._state)  # each world's state row, a live view
        # where qpos and qvel lie in a state row
        self._qpos = self._component(mujoco.mjtState.mjSTATE_QPOS)
        self._qvel = self._component(mujoco.mjtState.mjSTATE_QVEL)
        self._datas = [env.world.data for env in self.envs]
        self._ctrl = self._batch.bind("ctrl")  # the rows' controls, a view
        space = first.action_space
        self._action_low, self._action_high = space.low, space.high
        self._elapsed = np.zeros(num_envs, np.int64)
        self._autoreset = np.zeros(num_envs, np.bool_)

    def _component(self, component: mujoco.mjtState) -> slice:
        """The columns of one component (mjSTATE_QPOS, ...) in the integration state."""
        before = int(component) - 1  # the components ordered before it
        start = mujoco.mj_stateSize(self.model, self._spec & before)
        return slice(start, start + mujoco.mj_stateSize(self.model, int(component)))

    @property
    def worlds(self) -> list[World]:
        """The sub-environments' worlds (same model)."""
        return [env.world for env in self.envs]

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
        observations = self.envs[0].empty_observations(self.num_envs)
        success = np.zeros(self.num_envs, np.bool_)
        for i, (env, env_seed) in enumerate(zip(self.envs, seeds, strict=True)):
            success[i] = env.begin_episode(env_seed)
            env.observe_into(observations, i)
        self._elapsed[:] = 0
        self._autoreset[:] = False
        return observations, self._info(success)

    def step(self, actions: NDArray[Any]) -> VectorStep:
        """One step of every world (worlds whose episode ended last step are reset instead)."""
        clipped = self._clip(actions)
        rows = list(clipped)  # one view per world, made once
        count, model, spec, frame_skip = self.num_envs, self.model, self._spec, self.frame_skip
        resetting = self._autoreset
        worlds = list(
            zip(self.envs, self._datas, self._rows, rows, resetting.tolist(), strict=True)
        )
        held: list[int] = []  # worlds whose drives' ctrl holds over the frame skip
        varying: dict[int, NDArray[np.float64]] = {}  # the others' ctrl, one row per substep
        for i, (env, data, state, action, resets) in enumerate(worlds):
            if resets:
                continue
            ctrl = env.action.controls(env.world, action, frame_skip)
            mujoco.mj_getState(model, data, state, spec)
            if ctrl is None:
                held.append(i)
            else:
                varying[i] = ctrl
        self._simulate(held, varying)
        observations = self.envs[0].empty_observations(count)
        rewards = np.zeros(count, np.float64)
        terminated = np.zeros(count, np.bool_)
        success = np.zeros(count, np.bool_)
        stepped: list[int] = []
        for i, (env, data, state, _, resets) in enumerate(worlds):
            if resets:
                success[i] = env.begin_episode()
                env.observe_into(observations, i)
            else:
                mujoco.mj_setState(model, data, state, spec)
                env.refresh()
                stepped.append(i)
        if stepped:
            self._finish(
                stepped,
                actions=clipped if len(stepped) == count else clipped[stepped],
                observations=observations,
                rewards=rewards,
                success=success,
                terminated=terminated,
            )
        self._elapsed = np.where(resetting, 0, self._elapsed + 1)
        limit = self.max_episode_steps
        truncated = ~resetting & (limit is not None) & (self._elapsed >= (limit or 0))
        self._autoreset = terminated | truncated
        return observations, rewards, terminated, truncated, self._info(success)

    def _finish(
        self,
        stepped: list[int],
        *,
        actions: NDArray[np.float32],
        observations: Observation,
        rewards: NDArray[np.float64],
        success: NDArray[np.bool_],
        terminated: NDArray[np.bool_],
    ) -> None:
        """Reward, success, termination and observation of the worlds in `stepped` (their
        data up to date), over all of them at once where the task allows
        (`Task.evaluate_many`, `SceneEnv.observe_many`)."""
        everyone = len(stepped) == self.num_envs  # the usual case: basic indexing, no copies
        rows: list[int] | slice = slice(None) if everyone else stepped
        envs = self.envs if everyone else [self.envs[i] for i in stepped]
        goals = np.array([env.goal for env in envs])
        tasks = [env.task for env in envs]
        worlds = [env.world for env in envs]
        reward, solved, ended = type(tasks[0]).evaluate_many(tasks, worlds, goals, actions)
        if not math.isfinite(float(reward.sum())):
            raise GymError(f"task {type(tasks[0]).__name__} returned rewards {reward}")
        rewards[rows], success[rows], terminated[rows] = reward, solved, ended
        state = self._state[rows]
        SceneEnv.observe_many(
            envs,
            observations,
            rows,
            qpos=state[:, self._qpos],
            qvel=state[:, self._qvel],
            goals=goals,
        )

    def _simulate(self, held: list[int], varying: dict[int, NDArray[np.float64]]) -> None:
        """`frame_skip` physics steps of the rows of `held` (their ctrl as it is) and of
        `varying` (a ctrl row per substep), each kind in one batch call per call."""
        if held:
            ids = None if len(held) == self.num_envs else np.array(held, np.int32)
            self._batch.step(ids, nstep=self.frame_skip)
        if varying:
            ids = np.array(list(varying), np.int32)
            rows = np.stack(list(varying.values()))  # (worlds, substeps, nu)
            for substep in range(rows.shape[1]):
                self._ctrl[ids] = rows[:, substep]
                self._batch.step(ids)

    def _clip(self, actions: NDArray[Any]) -> NDArray[np.float32]:
        """Every world's action at once, as `SceneEnv.clip_action` clips one."""
        array = np.asarray(actions, dtype=np.float32)
        if array.shape != self.action_space.shape:
            raise GymError(
                f"actions must have shape {self.action_space.shape}, got {np.shape(actions)}"
            )
        if not math.isfinite(float(array.sum())):
            raise GymError(f"actions must be finite, got {actions!r}")
        return np.minimum(np.maximum(array, self._action_low), self._action_high)

    def _info(self, success: NDArray[np.bool_]) -> dict[str, Any]:
        """Gymnasium's vector info layout (key -> array, "_key" -> mask): every world
        reports "is_success" on every step and reset."""
        return {"is_success": success, "_is_success": np.ones(self.num_envs, np.bool_)}

    def render(self) -> tuple[NDArray[np.uint8], ...] | None:
        """One frame per world when render_mode is "rgb_array"."""
        if self.render_mode != "rgb_array":
            return None
        frames = [env.render() for env in self.envs]
        return tuple(frame for frame in frames if frame is not None)

    def close_extras(self, **kwargs: Any) -> None:
        """Free the worlds' renderers."""
        for env in self.envs:
            env.close()
