"""ARS with its rollouts on Ray actors: one actor per worker, each with its own vector env.

The learner (`simbridge.gym.ars.learn_ars`) runs in the driver. Each iteration it ships
the policy once (`ray.put`) and each worker a few direction offsets and seeds; the
workers rebuild the directions from the noise table, which went to the object store once,
run their share of the episode pairs on their own `SceneVectorEnv`, and send back returns
and the features their worlds saw. `Episodes.join` puts those in the order one vector
would have produced, so the result is the local learner's for the same config and seed
(bit for bit on one machine; see docs/ray.md).
"""

from __future__ import annotations

import itertools
import time
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from simbridge.cluster.runtime import connect, node_id, ray_module
from simbridge.errors import ClusterError
from simbridge.gym.ars import (
    ARSConfig,
    ARSResult,
    CurvePoint,
    Episodes,
    LinearPolicy,
    VectorRollouts,
    learn_ars,
    noise_table,
)

__all__ = [
    "MAX_RESTARTS",
    "START_TIMEOUT_S",
    "Call",
    "RayRollouts",
    "RayTraining",
    "RolloutWorker",
    "WorkReport",
    "make_vector",
    "shares",
    "train_ars_on_ray",
]

START_TIMEOUT_S = 180.0
"""How long the workers may take to start (a worker needs a free CPU in the cluster)."""

MAX_RESTARTS = 3
"""Workers that may die and be replaced in one run before it fails."""


def make_vector(
    env_id: str, num_envs: int, max_steps: int, env_kwargs: Mapping[str, Any], threads: int = 0
) -> gym.vector.VectorEnv[Any, Any, Any]:
    """The vector env ARS runs on, here or in a worker: `num_envs` worlds of `env_id`
    (a simbridge id: a `SceneVectorEnv`; importing simbridge.gym, as this module does,
    registers them), episodes cut at `max_steps`."""
    return gym.make_vec(
        env_id, num_envs=num_envs, max_episode_steps=max_steps, threads=threads, **env_kwargs
    )


def shares(total: int, parts: int) -> list[int]:
    """`total` split into `parts` near-equal contiguous counts, larger ones first."""
    return [total // parts + (1 if i < total % parts else 0) for i in range(parts)]


@dataclass(frozen=True)
class WorkReport:
    """Where a worker's call ran and for how long it computed (s)."""

    node: str
    busy_s: float


class RolloutWorker:
    """What one Ray actor holds: a vector env of two worlds per direction it runs (one
    physics thread: the actor has one CPU), the noise table, and where it runs.

    `table` is a one-element list holding the noise table's object ref: the actor reads
    the object store's copy itself (a read-only view, no copy on the driver's node)."""

    def __init__(
        self,
        env_id: str,
        directions: int,
        max_steps: int,
        table: list[Any],
        env_kwargs: Mapping[str, Any],
    ) -> None:
        vec = make_vector(env_id, 2 * directions, max_steps, env_kwargs, threads=1)
        self.rollouts = VectorRollouts(vec, max_steps, ray_module().get(table[0]))
        self.node = node_id()

    def spaces(self) -> tuple[spaces.Space[Any], spaces.Space[Any], str]:
        """The single env's observation and action spaces, and this worker's node id."""
        vec = self.rollouts.vec
        return vec.single_observation_space, vec.single_action_space, self.node

    def perturbed(
        self, policy: LinearPolicy, noise: float, offsets: Sequence[int], seeds: Sequence[int]
    ) -> tuple[Episodes, WorkReport]:
        """`VectorRollouts.perturbed` on this worker, and where and how long it ran."""
        start = time.perf_counter()
        episodes = self.rollouts.perturbed(policy, noise, offsets, seeds)
        return episodes, WorkReport(node_id(), time.perf_counter() - start)

    def evaluate(self, policy: LinearPolicy, seeds: Sequence[int]) -> tuple[Episodes, WorkReport]:
        """`VectorRollouts.evaluate` on this worker, and where and how long it ran."""
        start = time.perf_counter()
        episodes = self.rollouts.evaluate(policy, seeds)
        return episodes, WorkReport(node_id(), time.perf_counter() - start)


Spawn = Callable[[int], Any]
"""Starts a worker actor for that many directions (its handle; not waited for)."""


class RayRollouts:
    """`Rollouts` on Ray actors: worker k runs directions `directions[k]` of each
    iteration and a proportional share of the evaluation seeds. A worker that dies (its
    process killed, its node lost) is replaced and its call sent again, up to
    `MAX_RESTARTS` times a run: episodes are pure functions of the call, so the retry
    gives what the lost call would have. Counts the episodes each node ran, and keeps
    each batch's wall time and its workers' busy times (`batches`)."""

    def __init__(self, ray: Any, spawn: Spawn, directions: Sequence[int]) -> None:
        self._ray, self._spawn, self._directions = ray, spawn, list(directions)
        self._workers = [spawn(count) for count in self._directions]
        self.nodes: list[str] = []
        """The node of each worker (of its replacement, after a restart)."""
        self.restarts = 0
        self.episodes_per_node: Counter[str] = Counter()
        self.batches: list[tuple[float, list[WorkReport]]] = []

    def start(self) -> tuple[spaces.Dict, spaces.Box]:
        """Wait until every worker has built its env; the env's spaces."""
        observation, action, _ = self._ready(list(range(len(self._workers))))[0]
        if not isinstance(observation, spaces.Dict) or not isinstance(action, spaces.Box):
            raise ClusterError(
                f"ARS needs Dict observations and Box actions, the env has {observation} "
                f"and {action}"
            )
        return observation, action

    def _ready(self, which: list[int]) -> list[tuple[Any, Any, str]]:
        pending = [self._workers[k].spaces.remote() for k in which]
        ready, _ = self._ray.wait(pending, num_returns=len(pending), timeout=START_TIMEOUT_S)
        if len(ready) < len(pending):
            cpus = self._ray.cluster_resources().get("CPU", 0)
            raise ClusterError(
                f"{len(ready)} of {len(pending)} ARS workers started in "
                f"{START_TIMEOUT_S:.0f} s; each needs a CPU and the cluster has {cpus:g}: "
                "ask for fewer (--workers)"
            )
        try:
            answers: list[tuple[Any, Any, str]] = self._ray.get(pending)
        except self._ray.exceptions.RayError as exc:
            raise ClusterError(f"an ARS worker failed to start: {exc}") from exc
        self.nodes += [""] * (len(self._workers) - len(self.nodes))
        for k, (_, _, node) in zip(which, answers, strict=True):
            self.nodes[k] = node
        return answers

    def stop(self) -> None:
        """End every worker."""
        for worker in self._workers:
            self._ray.kill(worker)

    def _gather(self, start: float, calls: Sequence[Call], worlds: int) -> Episodes:
        """Each call's answer (calls to dead workers sent again to their replacement),
        joined into one batch of `worlds`."""
        refs = [call.send(self._workers[call.worker]) for call in calls]
        results: list[tuple[Episodes, WorkReport]] = []
        for call, first in zip(calls, refs, strict=True):
            sent = first
            while True:
                try:
                    results.append(self._ray.get(sent))
                    break
                except self._ray.exceptions.RayActorError as exc:
                    self._replace(call.worker, exc)
                    sent = call.send(self._workers[call.worker])
                except self._ray.exceptions.RayError as exc:
                    raise ClusterError(f"ARS worker {call.worker} failed: {exc}") from exc
        self.batches.append((time.perf_counter() - start, [report for _, report in results]))
        parts = []
        for (episodes, report), call in zip(results, calls, strict=True):
            self.episodes_per_node[report.node] += len(episodes.returns)
            parts.append((episodes, call.columns))
        return Episodes.join(parts, worlds)

    def _replace(self, k: int, error: Exception) -> None:
        if self.restarts >= MAX_RESTARTS:
            raise ClusterError(
                f"ARS worker {k} died after {self.restarts} restarts in this run: {error}"
            ) from error
        self.restarts += 1
        self._ray.kill(self._workers[k])
        self._workers[k] = self._spawn(self._directions[k])
        self._ready([k])

    def perturbed(
        self, policy: LinearPolicy, noise: float, offsets: Sequence[int], seeds: Sequence[int]
    ) -> Episodes:
        """See `Rollouts.perturbed`: worker k's pairs are worlds first..last and
        n + first..n + last of the one-vector layout."""
        n = len(offsets)
        if n != sum(self._directions):
            raise ClusterError(f"workers hold {sum(self._directions)} directions, got {n}")
        start = time.perf_counter()
        shared = self._ray.put(policy)
        calls, first = [], 0
        for k, count in enumerate(self._directions):
            part = slice(first, first + count)
            args = (shared, noise, offsets[part], seeds[part])
            columns = [*range(first, first + count), *range(n + first, n + first + count)]
            calls.append(Call(k, "perturbed", args, columns))
            first += count
        return self._gather(start, calls, 2 * n)

    def evaluate(self, policy: LinearPolicy, seeds: Sequence[int]) -> Episodes:
        """See `Rollouts.evaluate`: contiguous runs of seeds, in proportion to each
        worker's worlds."""
        total = sum(self._directions)
        bounds = [0, *(round(len(seeds) * c / total) for c in np.cumsum(self._directions))]
        start = time.perf_counter()
        shared = self._ray.put(policy)
        calls = [
            Call(k, "evaluate", (shared, seeds[lo:hi]), range(lo, hi))
            for k, (lo, hi) in enumerate(itertools.pairwise(bounds))
            if hi > lo
        ]
        return self._gather(start, calls, len(seeds))


@dataclass(frozen=True)
class Call:
    """One worker's part of a batch: which worker, which method with which arguments,
    and which worlds of the batch its answer fills."""

    worker: int
    method: str
    args: tuple[Any, ...]
    columns: Sequence[int]

    def send(self, worker: Any) -> Any:
        """The call sent to `worker` (an actor handle); its object ref."""
        return getattr(worker, self.method).remote(*self.args)


@dataclass
class RayTraining:
    """An ARS run on a cluster: the result, and where its work ran."""

    result: ARSResult
    worker_nodes: list[str]
    """The node id each worker (actor) ran on (its replacement's, if it was restarted)."""
    episodes_per_node: dict[str, int] = field(default_factory=dict)
    """Episodes each node ran (reported by the workers with each batch)."""
    busy_s_per_node: dict[str, float] = field(default_factory=dict)
    """Seconds the workers of each node spent running episodes."""
    batches_s: float = 0.0
    """Seconds the learner waited for batches of episodes, in all."""
    overhead_s: float = 0.0
    """Of `batches_s`, what the slowest worker of each batch did not spend computing:
    Ray's calls, moving policy and features, joining."""
    cluster_cpus: float = 0.0
    restarts: int = 0
    """Workers that died and were replaced during the run."""

    @classmethod
    def of(cls, result: ARSResult, rollouts: RayRollouts, cpus: float) -> RayTraining:
        """The record of a finished run on `rollouts`."""
        busy: dict[str, float] = {}
        for _, reports in rollouts.batches:
            for report in reports:
                busy[report.node] = busy.get(report.node, 0.0) + report.busy_s
        return cls(
            result,
            list(rollouts.nodes),
            dict(rollouts.episodes_per_node),
            busy,
            sum(wall for wall, _ in rollouts.batches),
            sum(wall - max(r.busy_s for r in reports) for wall, reports in rollouts.batches),
            cpus,
            rollouts.restarts,
        )


def train_ars_on_ray(
    env_id: str,
    max_steps: int,
    config: ARSConfig | None = None,
    *,
    address: str = "auto",
    workers: int | None = None,
    env_kwargs: Mapping[str, Any] | None = None,
    progress: Callable[[CurvePoint], None] | None = None,
) -> RayTraining:
    """Train as `train_ars` on `gym.make_vec(env_id, 2 * directions, ...)` would, with
    the rollouts on `workers` Ray actors (default: one per CPU of the cluster, at most one
    per direction) of the cluster at `address`."""
    cfg = config or ARSConfig()
    if cfg.directions < 1:
        raise ClusterError(f"ARS directions must be >= 1, got {cfg.directions}")
    with connect(address) as ray:
        cpus = float(ray.cluster_resources().get("CPU", 0))
        count = workers if workers is not None else max(1, int(cpus))
        if count < 1:
            raise ClusterError(f"--workers must be >= 1, got {count}")
        split = [n for n in shares(cfg.directions, count) if n > 0]
        table = noise_table(cfg)
        table_ref = ray.put(table)  # once: every worker reads the object store's copy
        worker_class = ray.remote(num_cpus=1)(RolloutWorker)
        kwargs = dict(env_kwargs or {})

        def spawn(directions: int) -> Any:
            return worker_class.options(scheduling_strategy="SPREAD").remote(
                env_id, directions, max_steps, [table_ref], kwargs
            )

        rollouts = RayRollouts(ray, spawn, split)
        try:
            obs_space, act_space = rollouts.start()
            policy = LinearPolicy.zeros(obs_space, act_space, cfg.keys)
            result = learn_ars(rollouts, policy, table, cfg, progress)
        finally:
            rollouts.stop()
        return RayTraining.of(result, rollouts, cpus)
