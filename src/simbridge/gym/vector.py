"""`SceneVectorEnv`: many worlds on one compiled model, stepped on a pool of threads.

Every sub-environment is a `SceneEnv` on a `World.clone()` of the first (one `MjModel`,
one `MjData` each). A vector step hands each thread one contiguous chunk of worlds and
steps them there, action to observation: `mujoco.mj_step(..., nstep=frame_skip)` releases
the GIL, so one thread's physics runs while another does its Python (drive targets,
observations, rewards), and the physics of N worlds spreads over the cores. Each world
steps exactly as it would alone: a sub-environment matches its single-env twin bit for
bit. Autoreset follows Gymnasium's default (next step): the step after an episode ended
resets that world and returns its first observation with reward 0.
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from simbridge.errors import GymError
from simbridge.gym.env import Observation, SceneEnv
from simbridge.gym.sensors import CameraImage
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
    is the thread count (0: one per CPU; worlds with camera observations use one, as an
    OpenGL context belongs to the thread that made it).
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
        if any(isinstance(s, CameraImage) for s in first.sensors):
            threads = 1
        self._threads = max(1, min(threads or os.cpu_count() or 1, num_envs))
        # chunks of consecutive worlds, one per thread; the calling thread takes the first
        edges = np.linspace(0, num_envs, self._threads + 1).round().astype(int).tolist()
        self._bounds = list(itertools.pairwise(edges))
        self._pool = (
            ThreadPoolExecutor(self._threads - 1, thread_name_prefix="simbridge-gym")
            if self._threads > 1
            else None
        )
        space = first.action_space
        self._action_low, self._action_high = space.low, space.high
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
        clipped = self._clip(actions)
        count = self.num_envs
        observations: list[Observation] = [{}] * count
        rewards = np.zeros(count, np.float64)
        terminated = np.zeros(count, np.bool_)
        infos: list[dict[str, Any]] = [{}] * count
        resetting = self._autoreset
        envs = self.envs

        def run(start: int, stop: int) -> None:
            for i in range(start, stop):
                env = envs[i]
                if resetting[i]:
                    observations[i], infos[i] = env.reset()
                    continue
                action = clipped[i]
                env.simulate(env.action.controls(env.world, action, env.frame_skip))
                observations[i], rewards[i], terminated[i], _, infos[i] = env.finish_step(action)

        bounds = self._bounds
        futures = [] if self._pool is None else [self._pool.submit(run, *b) for b in bounds[1:]]
        run(*bounds[0])  # the calling thread steps the first chunk meanwhile
        for future in futures:
            future.result()
        self._elapsed = np.where(resetting, 0, self._elapsed + 1)
        limit = self.max_episode_steps
        truncated = ~resetting & (limit is not None) & (self._elapsed >= (limit or 0))
        self._autoreset = terminated | truncated
        return self._stack(observations), rewards, terminated, truncated, self._batch_infos(infos)

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

    def _batch_infos(self, infos: list[dict[str, Any]]) -> dict[str, Any]:
        """Gymnasium's vector info layout (key -> array, "_key" -> mask), in one pass when
        every world reports the same keys (the usual case)."""
        keys = set(infos[0])
        if any(set(info) != keys for info in infos):
            out: dict[str, Any] = {}
            for i, info in enumerate(infos):
                out = self._add_info(out, info, i)
            return out
        batched: dict[str, Any] = {}
        for key in keys:
            batched[key] = np.array([info[key] for info in infos])
            batched[f"_{key}"] = np.ones(len(infos), np.bool_)
        return batched

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
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None
        for env in self.envs:
            env.close()
