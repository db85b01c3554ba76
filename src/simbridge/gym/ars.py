"""Augmented random search (ARS V2-t, Mania et al. 2018): a linear policy, NumPy only.

Light enough to prove an environment learns on two CPU cores in minutes, without a
deep-learning framework. Episodes run in lockstep on a vector env (one world per
perturbation: `2 * directions` worlds), so the physics of a whole iteration is batched.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import VectorEnv
from numpy.typing import NDArray

from simbridge.errors import GymError

__all__ = ["ARSConfig", "ARSResult", "CurvePoint", "LinearPolicy", "run_episodes", "train_ars"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ARSConfig:
    """Hyper-parameters (the paper's names: N directions, b best, alpha, nu)."""

    directions: int = 8
    top: int = 4
    step_size: float = 0.1
    noise: float = 0.1
    iterations: int = 60
    eval_episodes: int = 32
    eval_every: int = 5
    target_success: float | None = 0.9
    """Stop once an evaluation reaches this success rate (None: run every iteration)."""
    time_budget_s: float | None = None
    seed: int = 0
    keys: tuple[str, ...] | None = None
    """Observation entries the policy sees (None: every 1-D entry)."""


@dataclass
class LinearPolicy:
    """action = centre + half_range * clip(W [(x - mean) / std, 1], -1, 1) on the flattened
    observation `keys`: W works in normalised units on both sides, so one step size and
    noise level suit any observation scale and any action units."""

    keys: tuple[str, ...]
    weights: FloatArray
    low: FloatArray
    high: FloatArray
    mean: FloatArray
    var: FloatArray
    count: float = 1e-4

    @classmethod
    def zeros(
        cls,
        observation_space: spaces.Dict,
        action_space: spaces.Box,
        keys: tuple[str, ...] | None = None,
    ) -> LinearPolicy:
        """A policy that outputs the action space's centre, reading `keys` (default: every
        1-D entry, images left out)."""
        if keys is None:
            keys = tuple(
                sorted(k for k, s in observation_space.spaces.items() if len(s.shape or ()) == 1)
            )
        unknown = sorted(set(keys) - set(observation_space.spaces))
        if unknown:
            raise GymError(
                f"policy keys {unknown} are not observed; observation has "
                f"{sorted(observation_space.spaces)}"
            )
        size = sum(int(np.prod(observation_space.spaces[k].shape or ())) for k in keys)
        act = int(action_space.shape[0])
        return cls(
            keys,
            np.zeros((act, size + 1)),
            action_space.low.astype(np.float64),
            action_space.high.astype(np.float64),
            np.zeros(size),
            np.ones(size),
        )

    def features(self, obs: dict[str, NDArray[Any]]) -> FloatArray:
        """The flattened observation(s): (obs_size,) or (batch, obs_size)."""
        return np.concatenate([np.asarray(obs[k], np.float64) for k in self.keys], axis=-1)

    def normalize(self, x: FloatArray) -> FloatArray:
        """Whitened features (running statistics) and a constant 1 for the bias column."""
        whitened = (x - self.mean) / np.sqrt(self.var + 1e-8)
        return np.concatenate([whitened, np.ones((*whitened.shape[:-1], 1))], axis=-1)

    def scale(self, normalised: FloatArray) -> NDArray[np.float32]:
        """Actions in the action space's units from outputs in [-1, 1] (clipped there)."""
        half = (self.high - self.low) / 2
        return (self.low + half + half * np.clip(normalised, -1.0, 1.0)).astype(np.float32)

    def __call__(self, obs: dict[str, NDArray[Any]]) -> NDArray[np.float32]:
        """The action for one observation."""
        return self.scale(self.weights @ self.normalize(self.features(obs)))

    def update_statistics(self, batch: FloatArray) -> None:
        """Merge a (n, obs_size) batch of features into the running mean and variance."""
        n = len(batch)
        if n == 0:
            return
        mean, var = batch.mean(axis=0), batch.var(axis=0)
        total = self.count + n
        delta = mean - self.mean
        self.mean = self.mean + delta * n / total
        self.var = (self.var * self.count + var * n + delta**2 * self.count * n / total) / total
        self.count = total


@dataclass(frozen=True)
class CurvePoint:
    """One evaluation on the learning curve."""

    iteration: int
    env_steps: int
    wall_s: float
    mean_return: float
    success_rate: float


@dataclass
class ARSResult:
    """The trained policy and its learning curve."""

    policy: LinearPolicy
    curve: list[CurvePoint] = field(default_factory=list)

    @property
    def success_rate(self) -> float:
        """The last evaluation's success rate."""
        return self.curve[-1].success_rate if self.curve else 0.0


def run_episodes(
    vec: VectorEnv[Any, Any, Any],
    policy: LinearPolicy,
    weights: FloatArray,
    seeds: Sequence[int],
    max_steps: int,
    *,
    record: list[FloatArray] | None = None,
) -> tuple[FloatArray, NDArray[np.bool_], int]:
    """One episode per world in lockstep, world i acting with `weights[i]`; returns
    (returns, successes, env steps taken). Features seen are appended to `record`."""
    n = vec.num_envs
    obs, _ = vec.reset(seed=list(seeds))  # type: ignore[arg-type]  # every vector env takes a list
    done = np.zeros(n, np.bool_)
    returns, successes, steps = np.zeros(n), np.zeros(n, np.bool_), 0
    for _ in range(max_steps):
        x = policy.features(obs)
        if record is not None:
            record.append(x[~done])
        actions = policy.scale(np.einsum("nao,no->na", weights, policy.normalize(x)))
        obs, reward, terminated, truncated, info = vec.step(actions)
        live = ~done
        steps += int(live.sum())
        returns += np.where(live, reward, 0.0)
        successes |= live & np.asarray(info.get("is_success", np.zeros(n, np.bool_)), np.bool_)
        done |= terminated | truncated
        if done.all():
            break
    return returns, successes, steps


def train_ars(
    vec: VectorEnv[Any, Any, Any],
    max_steps: int,
    config: ARSConfig | None = None,
    progress: Callable[[CurvePoint], None] | None = None,
) -> ARSResult:
    """Train a linear policy on `vec` (it must hold `2 * config.directions` worlds; episodes
    last at most `max_steps`), evaluating on fixed seeds every `eval_every` iterations."""
    cfg = config or ARSConfig()
    if vec.num_envs != 2 * cfg.directions:
        raise GymError(
            f"ARS with {cfg.directions} directions needs a vector of {2 * cfg.directions} "
            f"envs, got {vec.num_envs}"
        )
    if not 0 < cfg.top <= cfg.directions:
        raise GymError(f"ARS top must be in 1..{cfg.directions}, got {cfg.top}")
    obs_space, act_space = vec.single_observation_space, vec.single_action_space
    assert isinstance(obs_space, spaces.Dict)
    assert isinstance(act_space, spaces.Box)
    policy = LinearPolicy.zeros(obs_space, act_space, cfg.keys)
    rng = np.random.default_rng(cfg.seed)
    result = ARSResult(policy)
    eval_seeds = [1_000_000 + i for i in range(cfg.eval_episodes)]
    start, total_steps = time.perf_counter(), 0

    def evaluate(iteration: int) -> CurvePoint:
        rets, wins = [], []
        for first in range(0, len(eval_seeds), vec.num_envs):
            chunk = eval_seeds[first : first + vec.num_envs]
            seeds = chunk + [chunk[-1]] * (vec.num_envs - len(chunk))
            weights = np.broadcast_to(policy.weights, (vec.num_envs, *policy.weights.shape))
            r, s, _ = run_episodes(vec, policy, weights, seeds, max_steps)
            rets.extend(r[: len(chunk)].tolist())
            wins.extend(s[: len(chunk)].tolist())
        point = CurvePoint(
            iteration,
            total_steps,
            time.perf_counter() - start,
            float(np.mean(rets)),
            float(np.mean(wins)),
        )
        result.curve.append(point)
        if progress is not None:
            progress(point)
        return point

    evaluate(0)
    for iteration in range(1, cfg.iterations + 1):
        deltas = rng.standard_normal((cfg.directions, *policy.weights.shape))
        weights = np.concatenate(
            [policy.weights + cfg.noise * deltas, policy.weights - cfg.noise * deltas]
        )
        seeds = rng.integers(0, 2**31 - 1, cfg.directions).tolist() * 2
        seen: list[FloatArray] = []
        returns, _, steps = run_episodes(vec, policy, weights, seeds, max_steps, record=seen)
        total_steps += steps
        plus, minus = returns[: cfg.directions], returns[cfg.directions :]
        best = np.argsort(-np.maximum(plus, minus))[: cfg.top]
        spread = float(np.concatenate([plus[best], minus[best]]).std()) or 1.0
        step = np.einsum("k,kao->ao", plus[best] - minus[best], deltas[best])
        policy.weights = policy.weights + cfg.step_size / (cfg.top * spread) * step
        policy.update_statistics(np.concatenate(seen))
        out_of_time = (
            cfg.time_budget_s is not None and time.perf_counter() - start > cfg.time_budget_s
        )
        if iteration % cfg.eval_every == 0 or iteration == cfg.iterations or out_of_time:
            point = evaluate(iteration)
            if cfg.target_success is not None and point.success_rate >= cfg.target_success:
                break
        if out_of_time:
            break
    return result
