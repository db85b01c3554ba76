"""`SceneVectorEnv`: many worlds on one compiled model, their physics stepped in one batch.

Every sub-environment is a `SceneEnv` on a `World.clone()` of the first (one `MjModel`,
one `MjData` each). A vector step applies each action to its world's drives (Python),
then runs all the worlds' physics in one `mujoco.rollout` call: C++ threads that release
the GIL, so the physics of N worlds spreads over the cores. Observations, rewards and
termination are then computed per world. Autoreset follows Gymnasium's default
(next step): the step after an episode ended resets that world and returns its first
observation with reward 0.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from mujoco.rollout import Rollout
from numpy.typing import NDArray

from simbridge.errors import GymError
from simbridge.gym.env import Observation, SceneEnv
from simbridge.sim.world import World

__all__ = ["EnvFactory", "SceneVectorEnv"]

EnvFactory = Callable[..., SceneEnv]
"""Builds one `SceneEnv`; must accept `world=` (a world to reuse) and `render_mode=`."""

_STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS
VectorStep = tuple[
    Observation, NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_], dict[str, Any]
]


class SceneVectorEnv(VectorEnv[Observation, NDArray[np.float32], NDArray[Any]]):
    """`num_envs` copies of the environment `make_env(**env_kwargs)` builds, one model.

    `max_episode_steps` truncates episodes (as `TimeLimit` does for one env); `threads`
    is the physics thread count (0: one per CPU).
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
        nthread = max(1, min(threads or os.cpu_count() or 1, num_envs))
        self._rollout: Rollout | None = Rollout(nthread=nthread if nthread > 1 else 0)
        self._scratch = [mujoco.MjData(self.model) for _ in range(nthread)]
        self._nstate = mujoco.mj_stateSize(self.model, _STATE)
        self._elapsed = np.zeros(num_envs, np.int64)
        self._autoreset = np.zeros(num_envs, np.bool_)

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
        observations: list[Observation] = []
        infos: dict[str, Any] = {}
        for i, (env, env_seed) in enumerate(zip(self.envs, seeds, strict=True)):
            obs, info = env.reset(seed=env_seed, options=options)
            observations.append(obs)
            infos = self._add_info(infos, info, i)
        self._elapsed[:] = 0
        self._autoreset[:] = False
        return self._stack(observations), infos

    def step(self, actions: NDArray[Any]) -> VectorStep:
        """One step of every world (worlds whose episode ended last step are reset instead)."""
        actions = np.asarray(actions)
        if actions.shape != self.action_space.shape:
            raise GymError(
                f"actions must have shape {self.action_space.shape}, got {actions.shape}"
            )
        stepping = [i for i in range(self.num_envs) if not self._autoreset[i]]
        clipped = {i: self.envs[i].clip_action(actions[i]) for i in stepping}
        ctrl = {
            i: self.envs[i].action.controls(self.envs[i].world, clipped[i], self.envs[i].frame_skip)
            for i in stepping
        }
        self._simulate(stepping, ctrl)
        observations: list[Observation] = []
        rewards = np.zeros(self.num_envs)
        terminated = np.zeros(self.num_envs, np.bool_)
        truncated = np.zeros(self.num_envs, np.bool_)
        infos: dict[str, Any] = {}
        for i, env in enumerate(self.envs):
            if self._autoreset[i]:
                obs, info = env.reset()
                self._elapsed[i] = 0
            else:
                obs, rewards[i], terminated[i], _, info = env.finish_step(clipped[i])
                self._elapsed[i] += 1
                limit = self.max_episode_steps
                truncated[i] = limit is not None and self._elapsed[i] >= limit
            observations.append(obs)
            infos = self._add_info(infos, info, i)
        self._autoreset = terminated | truncated
        return self._stack(observations), rewards, terminated, truncated, infos

    def _simulate(self, indices: list[int], ctrl: dict[int, NDArray[np.float64]]) -> None:
        """Physics of the worlds `indices` in one multi-threaded rollout."""
        if not indices:
            return
        assert self._rollout is not None, "the vector env is closed"
        model = self.model
        steps = self.envs[indices[0]].frame_skip
        state = np.empty((len(indices), self._nstate))
        warmstart = np.empty((len(indices), model.nv))
        control = np.empty((len(indices), steps, model.nu))
        for row, i in enumerate(indices):
            data = self.envs[i].world.data
            mujoco.mj_getState(model, data, state[row], _STATE)
            warmstart[row] = data.qacc_warmstart
            control[row] = ctrl[i]  # broadcasts a constant (nu,) row over the steps
        trajectory, _ = self._rollout.rollout(
            model, self._scratch, state, control, nstep=steps, initial_warmstart=warmstart
        )
        for row, i in enumerate(indices):
            data = self.envs[i].world.data
            mujoco.mj_setState(model, data, trajectory[row, -1], _STATE)
            data.ctrl[:] = control[row, -1]
            mujoco.mj_kinematics(model, data)

    def _stack(self, observations: list[Observation]) -> Observation:
        space = self.single_observation_space
        assert isinstance(space, spaces.Dict)
        return {key: np.stack([obs[key] for obs in observations]) for key in space.spaces}

    def render(self) -> tuple[NDArray[np.uint8], ...] | None:
        """One frame per world when render_mode is "rgb_array"."""
        if self.render_mode != "rgb_array":
            return None
        frames = [env.render() for env in self.envs]
        return tuple(frame for frame in frames if frame is not None)

    def close_extras(self, **kwargs: Any) -> None:
        """Stop the physics threads and free the worlds' renderers."""
        if self._rollout is not None:
            self._rollout.close()
            self._rollout = None
        for env in self.envs:
            env.close()
