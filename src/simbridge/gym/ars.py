"""Augmented random search (ARS V2-t, Mania et al. 2018): a linear policy, NumPy only.

Light enough to prove an environment learns on two CPU cores in minutes, without a
deep-learning framework. Episodes run in lockstep on a vector env (one world per
perturbation: `2 * directions` worlds), so the physics of a whole iteration is batched.

As in the paper's implementation, a perturbation direction is an offset into a shared
table of Gaussian samples: whoever holds the table rebuilds a direction from one integer,
so rollouts can run elsewhere (`simbridge.cluster` runs them on Ray actors) while the
learner ships only offsets and seeds. The learner (`learn_ars`) talks to its rollouts
through `Rollouts`; `VectorRollouts` runs them on one vector env.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from gymnasium import spaces
from gymnasium.vector import VectorEnv
from numpy.typing import NDArray

from simbridge.errors import GymError

__all__ = [
    "ARSConfig",
    "ARSResult",
    "CurvePoint",
    "Episodes",
    "LinearPolicy",
    "Rollouts",
    "VectorRollouts",
    "learn_ars",
    "noise_table",
    "run_episodes",
    "table_deltas",
    "train_ars",
]

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
    noise_table_size: int = 1 << 20
    """Gaussian samples in the noise table (8 MiB); a direction is a slice of it."""


def noise_table(config: ARSConfig) -> FloatArray:
    """The table of standard normal samples that directions are slices of (from the seed)."""
    if config.noise_table_size < 1:
        raise GymError(f"noise_table_size must be >= 1, got {config.noise_table_size}")
    return np.random.default_rng([config.seed, 1]).standard_normal(config.noise_table_size)


def table_deltas(table: FloatArray, offsets: Sequence[int], shape: tuple[int, ...]) -> FloatArray:
    """The directions at `offsets`: (len(offsets), *shape), each a contiguous slice."""
    size = int(np.prod(shape))
    if not offsets:
        return np.zeros((0, *shape))
    return np.stack([table[o : o + size] for o in offsets]).reshape(len(offsets), *shape)


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

    def save(self, path: str | Path) -> None:
        """Write the policy to an .npz file (`LinearPolicy.load` reads it back)."""
        np.savez(
            path,
            keys=np.array(self.keys, dtype=np.str_),
            weights=self.weights,
            low=self.low,
            high=self.high,
            mean=self.mean,
            var=self.var,
            count=np.float64(self.count),
        )

    @classmethod
    def load(cls, path: str | Path) -> LinearPolicy:
        """A policy `save` wrote."""
        try:
            with np.load(path) as data:
                return cls(
                    tuple(str(k) for k in data["keys"]),
                    data["weights"],
                    data["low"],
                    data["high"],
                    data["mean"],
                    data["var"],
                    float(data["count"]),
                )
        except (OSError, KeyError, ValueError) as exc:
            raise GymError(f"{path}: not a policy written by LinearPolicy.save ({exc})") from exc


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


@dataclass
class Episodes:
    """One episode per world, run in lockstep: what the learner reads from a batch."""

    returns: FloatArray
    successes: NDArray[np.bool_]
    steps: int
    """Env steps taken by worlds whose episode was still running."""
    live: NDArray[np.bool_] | None = None
    """(steps, worlds): world w was still running at step t (when features were kept)."""
    features: FloatArray | None = None
    """The features the live worlds saw, step after step, world after world in a step."""

    @classmethod
    def join(cls, parts: Sequence[tuple[Episodes, Sequence[int]]], worlds: int) -> Episodes:
        """Episodes of disjoint sets of worlds (each part with the worlds it ran, in its
        order) as if one vector of `worlds` had run them all: same returns, same features
        in the same order."""
        returns, successes = np.zeros(worlds), np.zeros(worlds, np.bool_)
        covered = np.zeros(worlds, np.int64)
        for part, columns in parts:
            returns[list(columns)] = part.returns
            successes[list(columns)] = part.successes
            covered[list(columns)] += 1
        if not (covered == 1).all():
            raise GymError(f"parts cover worlds {covered.tolist()} times, not once each")
        steps = sum(part.steps for part, _ in parts)
        kept = [(p.live, p.features, c) for p, c in parts if p.live is not None]
        if not kept:
            return cls(returns, successes, steps)
        if len(kept) != len(parts):
            raise GymError("some parts kept their features and some did not")
        live = np.zeros((max(len(mask) for mask, _, _ in kept), worlds), np.bool_)
        for mask, _, columns in kept:
            live[: len(mask), list(columns)] = mask
        rank = np.cumsum(live.ravel()).reshape(live.shape) - 1  # (t, w)'s row in features
        features: FloatArray | None = None
        for mask, seen, columns in kept:
            assert seen is not None  # kept together with live
            if features is None:
                features = np.empty((int(live.sum()), seen.shape[1]))
            features[rank[: len(mask), list(columns)][mask]] = seen
        return cls(returns, successes, steps, live, features)


def run_episodes(
    vec: VectorEnv[Any, Any, Any],
    policy: LinearPolicy,
    weights: FloatArray,
    seeds: Sequence[int],
    max_steps: int,
    *,
    keep_features: bool = False,
) -> Episodes:
    """One episode per world in lockstep, world i acting with `weights[i]`, seeded
    `seeds[i]`; with `keep_features` the features the running worlds saw are kept."""
    n = vec.num_envs
    obs, _ = vec.reset(seed=list(seeds))  # type: ignore[arg-type]  # every vector env takes a list
    done = np.zeros(n, np.bool_)
    returns, successes, steps = np.zeros(n), np.zeros(n, np.bool_), 0
    live: list[NDArray[np.bool_]] = []
    seen: list[FloatArray] = []
    for _ in range(max_steps):
        x = policy.features(obs)
        if keep_features:
            live.append(~done)
            seen.append(x[~done])
        actions = policy.scale(np.einsum("nao,no->na", weights, policy.normalize(x)))
        obs, reward, terminated, truncated, info = vec.step(actions)
        running = ~done
        steps += int(running.sum())
        returns += np.where(running, reward, 0.0)
        successes |= running & np.asarray(info.get("is_success", np.zeros(n, np.bool_)), np.bool_)
        done |= terminated | truncated
        if done.all():
            break
    if not keep_features:
        return Episodes(returns, successes, steps)
    width = len(policy.mean)
    return Episodes(
        returns,
        successes,
        steps,
        np.array(live, np.bool_).reshape(len(live), n),
        np.concatenate(seen) if seen else np.zeros((0, width)),
    )


class Rollouts(Protocol):
    """Where the learner's episodes run: one vector env here, or workers elsewhere."""

    def perturbed(
        self, policy: LinearPolicy, noise: float, offsets: Sequence[int], seeds: Sequence[int]
    ) -> Episodes:
        """For each direction i (`offsets[i]` into the noise table), an episode with the
        weights plus `noise` times it (world i) and one with minus (world n + i), both
        seeded `seeds[i]`; features kept."""
        ...

    def evaluate(self, policy: LinearPolicy, seeds: Sequence[int]) -> Episodes:
        """One episode of `policy` per seed, in the order given."""
        ...


class VectorRollouts:
    """Rollouts on one vector env: perturbed pairs need exactly two worlds per direction,
    evaluations run in chunks of the vector's size."""

    def __init__(self, vec: VectorEnv[Any, Any, Any], max_steps: int, table: FloatArray) -> None:
        self.vec, self.max_steps, self.table = vec, max_steps, table

    def perturbed(
        self, policy: LinearPolicy, noise: float, offsets: Sequence[int], seeds: Sequence[int]
    ) -> Episodes:
        """See `Rollouts.perturbed`."""
        if self.vec.num_envs != 2 * len(offsets) or len(seeds) != len(offsets):
            raise GymError(
                f"{len(offsets)} directions and {len(seeds)} seeds on a vector of "
                f"{self.vec.num_envs} envs: need two envs and one seed per direction"
            )
        deltas = table_deltas(self.table, offsets, policy.weights.shape)
        weights = np.concatenate([policy.weights + noise * deltas, policy.weights - noise * deltas])
        seeds = [int(s) for s in seeds]
        return run_episodes(
            self.vec, policy, weights, seeds * 2, self.max_steps, keep_features=True
        )

    def evaluate(self, policy: LinearPolicy, seeds: Sequence[int]) -> Episodes:
        """See `Rollouts.evaluate`."""
        n = self.vec.num_envs
        weights = np.broadcast_to(policy.weights, (n, *policy.weights.shape))
        returns, successes, steps = [], [], 0
        for first in range(0, len(seeds), n):
            chunk = [int(s) for s in seeds[first : first + n]]
            padded = chunk + [chunk[-1]] * (n - len(chunk))
            part = run_episodes(self.vec, policy, weights, padded, self.max_steps)
            returns.append(part.returns[: len(chunk)])
            successes.append(part.successes[: len(chunk)])
            steps += part.steps
        if not returns:
            return Episodes(np.zeros(0), np.zeros(0, np.bool_), 0)
        return Episodes(np.concatenate(returns), np.concatenate(successes), steps)


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
    obs_space, act_space = vec.single_observation_space, vec.single_action_space
    assert isinstance(obs_space, spaces.Dict)
    assert isinstance(act_space, spaces.Box)
    policy = LinearPolicy.zeros(obs_space, act_space, cfg.keys)
    table = noise_table(cfg)
    return learn_ars(VectorRollouts(vec, max_steps, table), policy, table, cfg, progress)


def learn_ars(
    rollouts: Rollouts,
    policy: LinearPolicy,
    table: FloatArray,
    config: ARSConfig,
    progress: Callable[[CurvePoint], None] | None = None,
) -> ARSResult:
    """The ARS loop on any `Rollouts` (whose noise table is `table`), from `policy`: the
    same config, table and rollouts' episodes give the same result wherever they ran."""
    cfg = config
    if cfg.directions < 1:
        raise GymError(f"ARS directions must be >= 1, got {cfg.directions}")
    if not 0 < cfg.top <= cfg.directions:
        raise GymError(f"ARS top must be in 1..{cfg.directions}, got {cfg.top}")
    size = policy.weights.size
    if len(table) < size:
        raise GymError(
            f"noise table of {len(table)} samples is smaller than the policy's {size} weights"
        )
    rng = np.random.default_rng(cfg.seed)
    result = ARSResult(policy)
    eval_seeds = [1_000_000 + i for i in range(cfg.eval_episodes)]
    start, total_steps = time.perf_counter(), 0

    def evaluate(iteration: int) -> CurvePoint:
        episodes = rollouts.evaluate(policy, eval_seeds)
        point = CurvePoint(
            iteration,
            total_steps,
            time.perf_counter() - start,
            float(np.mean(episodes.returns)),
            float(np.mean(episodes.successes)),
        )
        result.curve.append(point)
        if progress is not None:
            progress(point)
        return point

    evaluate(0)
    for iteration in range(1, cfg.iterations + 1):
        offsets = rng.integers(0, len(table) - size + 1, cfg.directions).tolist()
        seeds = rng.integers(0, 2**31 - 1, cfg.directions).tolist()
        episodes = rollouts.perturbed(policy, cfg.noise, offsets, seeds)
        total_steps += episodes.steps
        plus, minus = episodes.returns[: cfg.directions], episodes.returns[cfg.directions :]
        best = np.argsort(-np.maximum(plus, minus))[: cfg.top]
        spread = float(np.concatenate([plus[best], minus[best]]).std()) or 1.0
        deltas = table_deltas(table, [offsets[i] for i in best], policy.weights.shape)
        step = np.einsum("k,kao->ao", plus[best] - minus[best], deltas)
        policy.weights = policy.weights + cfg.step_size / (cfg.top * spread) * step
        if episodes.features is None:
            raise GymError("the rollouts kept no features for the policy's statistics")
        policy.update_statistics(episodes.features)
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
