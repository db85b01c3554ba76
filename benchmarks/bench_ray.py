"""Ray scaling on this machine: ARS rollouts (env steps/s) and datagen frames (frames/s)
on 1 worker, 2 workers on one node and 2 nodes of 1 CPU each, beside the same work
without Ray, and Ray's overhead.

Datagen: the datagen demo scene (apps/datagen/scene.yaml, 640x480, COCO + BOP) as Ray
tasks of `DATAGEN_CHUNK` frames, `DATAGEN_FRAMES` frames a worker, timed after a warm-up
round (workers started, scenes built), and the driver's merge of the shards (`merge_s`,
serial: the part that does not scale).

Each layout is a fresh local cluster (`ray.cluster_utils.Cluster` on 127.0.0.2, private
RAY_TMPDIR, 100 MB object store a node); the learner's side is `RayRollouts.perturbed`,
one ARS iteration of Reach-v0 at a time, 8 directions (16 episodes of 50 steps) per
worker: a vector step costs about the same for 8 worlds as for 16 (Python per step, not
physics per world, dominates Reach-v0), so workers pay off by running more directions,
not by splitting a few. The rate is the best of `ROUNDS` rounds of at least `ROUND_S`.
"no Ray" rows run 8 and 16 directions on one `SceneVectorEnv` in this process (1 and 2
physics threads).
`iteration_ms`: the median wall time of one iteration's episodes; `overhead_ms`: of that,
what the slowest worker did not spend computing (Ray's calls, the policy out and the
features back, the join). `task_ms`: the round trip of an empty one-CPU task (median of
200, one at a time); `pipelined_task_ms`: the time per task with 200 in flight; and the
start of the cluster and of its workers (a worker imports simbridge and builds its
vector env).
"""

from __future__ import annotations

import functools
import importlib
import os
import shutil
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # also as a bare script

import numpy as np

from simbridge.cluster import RayRollouts, RolloutWorker, make_vector
from simbridge.cluster.shards import chunks, render_on_ray
from simbridge.gym import ARSConfig, LinearPolicy
from simbridge.gym.ars import Episodes, VectorRollouts, noise_table
from simbridge.perception.dataset import DatagenJob, merge_shards, render_frames

__all__ = ["LOOPBACK", "local_cluster", "run"]

ENV_ID = "simbridge/Reach-v0"
MAX_STEPS = 50
CONFIG = ARSConfig()
DATAGEN_SCENE = Path(__file__).resolve().parents[1] / "src/simbridge/apps/datagen/scene.yaml"
DATAGEN_CHUNK = 4
DATAGEN_FRAMES = 8
"""Frames a worker renders in the timed round (chunks of DATAGEN_CHUNK)."""
LAYOUTS = {
    "Ray, 1 worker (1 node, 1 CPU)": [1],
    "Ray, 2 workers on one node (2 CPUs)": [2],
    "Ray, 2 workers on 2 nodes (1 CPU each)": [1, 1],
}
"""Each Ray row's cluster: the CPUs of each of its nodes."""
PER_WORKER = 8
"""Directions (two worlds each) per worker: two workers run twice the directions."""
ROUND_S = 3.0
ROUNDS = 3
LOOPBACK = "127.0.0.2"  # Ray rewrites 127.0.0.1 to the routed IP (docs/ray.md)
OBJECT_STORE_BYTES = 100 * 1000 * 1000
TIMES = {
    "iteration_ms": 1,
    "overhead_ms": 1,
    "task_ms": 2,
    "pipelined_task_ms": 2,
    "cluster_start_s": 1,
    "workers_start_s": 1,
}
"""Overhead columns and their decimals."""


@contextmanager
def local_cluster(cpus_per_node: list[int]) -> Iterator[Any]:
    """A private cluster, one node per entry (its CPUs), this process its driver."""
    ray = importlib.import_module("ray")
    cluster_utils = importlib.import_module("ray.cluster_utils")
    folder = tempfile.mkdtemp(prefix="sbray", dir="/tmp")
    saved = {k: os.environ.get(k) for k in ("RAY_TMPDIR", "RAY_USAGE_STATS_ENABLED")}
    os.environ.update(RAY_TMPDIR=folder, RAY_USAGE_STATS_ENABLED="0")
    args = {"object_store_memory": OBJECT_STORE_BYTES, "node_ip_address": LOOPBACK}
    cluster = None
    try:
        cluster = cluster_utils.Cluster(
            initialize_head=True,
            head_node_args={**args, "num_cpus": cpus_per_node[0], "include_dashboard": False},
        )
        for cpus in cpus_per_node[1:]:
            cluster.add_node(**args, num_cpus=cpus)
        ray.init(address=cluster.address, logging_level="WARNING")
        cluster.wait_for_nodes()
        yield ray
    finally:
        ray.shutdown()
        if cluster is not None:
            cluster.shutdown()
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
        shutil.rmtree(folder, ignore_errors=True)


def _rate(iteration: Callable[[], Episodes]) -> float:
    """Env steps per second of `iteration`, best of ROUNDS rounds of at least ROUND_S."""
    iteration()  # warm
    best = 0.0
    for _ in range(ROUNDS):
        start, steps = time.perf_counter(), 0
        while time.perf_counter() - start < ROUND_S:
            steps += iteration().steps
        best = max(best, steps / (time.perf_counter() - start))
    return best


def _iteration(rollouts: Any, policy: LinearPolicy, directions: int) -> Callable[[], Episodes]:
    """One ARS iteration's episodes: fresh directions and seeds each call."""
    rng = np.random.default_rng(0)
    last = CONFIG.noise_table_size - policy.weights.size

    def one() -> Episodes:
        offsets = rng.integers(0, last, directions).tolist()
        seeds = rng.integers(0, 2**31 - 1, directions).tolist()
        episodes: Episodes = rollouts.perturbed(policy, CONFIG.noise, offsets, seeds)
        return episodes

    return one


def _policy(vec: Any) -> LinearPolicy:
    return LinearPolicy.zeros(vec.single_observation_space, vec.single_action_space)


def local_rows() -> list[dict[str, Any]]:
    """The rollouts in this process, no Ray."""
    rows = []
    table = noise_table(CONFIG)
    for threads in (1, 2):
        directions = PER_WORKER * threads
        vec = make_vector(ENV_ID, 2 * directions, MAX_STEPS, {}, threads=threads)
        policy = _policy(vec)
        rollouts = VectorRollouts(vec, MAX_STEPS, table)
        rate = _rate(_iteration(rollouts, policy, directions))
        vec.close()
        rows.append(
            {
                "layout": f"no Ray, one vector of {2 * directions}, {threads} thread(s)",
                "directions": directions,
                "rate": rate,
                "iteration_ms": 2 * directions * MAX_STEPS / rate * 1e3,
            }
        )
    return rows


def _task_overhead(ray: Any) -> tuple[float, float]:
    """An empty one-CPU task: median round trip one at a time (of 200), and the time per
    task when 200 are in flight at once, both in ms."""
    noop = ray.remote(num_cpus=1)(lambda: None)
    ray.get([noop.remote() for _ in range(4)])  # workers started
    alone = []
    for _ in range(200):
        start = time.perf_counter()
        ray.get(noop.remote())
        alone.append(time.perf_counter() - start)
    start = time.perf_counter()
    ray.get([noop.remote() for _ in range(200)])
    return statistics.median(alone) * 1e3, (time.perf_counter() - start) / 200 * 1e3


def _job() -> DatagenJob:
    return DatagenJob(str(DATAGEN_SCENE), seed=0)


def _datagen_row(ray: Any, workers: int, name: str) -> dict[str, Any]:
    """Frames/s of the datagen demo scene rendered as Ray tasks (chunks of
    `DATAGEN_CHUNK`, `DATAGEN_FRAMES` a worker), after a warm-up round that starts the
    workers and builds their scenes, and the driver's merge of those shards."""
    render = functools.partial(render_frames, _job())
    with tempfile.TemporaryDirectory(prefix="sbdatagen") as folder:
        root = Path(folder)
        render_on_ray(ray, render, chunks(DATAGEN_CHUNK * workers, DATAGEN_CHUNK), root / "warm")
        frames = DATAGEN_FRAMES * workers
        start = time.perf_counter()
        run = render_on_ray(ray, render, chunks(frames, DATAGEN_CHUNK), root / "shards")
        wall = time.perf_counter() - start
        start = time.perf_counter()
        merge_shards(_job(), run.shards, root / "out", frames)
        merge = time.perf_counter() - start
    return {
        "layout": name,
        "frames": frames,
        "frames_per_s": frames / wall,
        "nodes": len(set(run.nodes.values())),
        "merge_s": merge,
    }


def local_datagen_row() -> dict[str, Any]:
    """Frames/s of the same frames rendered in this process (no Ray), and their merge."""
    frames = DATAGEN_FRAMES
    with tempfile.TemporaryDirectory(prefix="sbdatagen") as folder:
        root = Path(folder)
        render_frames(_job(), range(DATAGEN_CHUNK), root / "warm")
        start = time.perf_counter()
        render_frames(_job(), range(frames), root / "shard")
        wall = time.perf_counter() - start
        start = time.perf_counter()
        merge_shards(_job(), [root / "shard"], root / "out", frames)
        merge = time.perf_counter() - start
    return {
        "layout": "no Ray, this process",
        "frames": frames,
        "frames_per_s": frames / wall,
        "nodes": "",
        "merge_s": merge,
    }


def ray_rows() -> list[dict[str, Any]]:
    """The rollouts on Ray actors, one cluster per layout."""
    rows = []
    for name, nodes in LAYOUTS.items():
        start = time.perf_counter()
        with local_cluster(nodes) as ray:
            cluster_s = time.perf_counter() - start
            task_ms, pipelined_ms = _task_overhead(ray)
            workers = sum(nodes)
            table_ref = ray.put(noise_table(CONFIG))
            split = [PER_WORKER] * workers
            actor = ray.remote(num_cpus=1)(RolloutWorker)

            def spawn(directions: int, actor: Any = actor, table_ref: Any = table_ref) -> Any:
                return actor.options(scheduling_strategy="SPREAD").remote(
                    ENV_ID, directions, MAX_STEPS, [table_ref], {}
                )

            start = time.perf_counter()
            rollouts = RayRollouts(ray, spawn, split)
            obs, act = rollouts.start()
            workers_s = time.perf_counter() - start
            policy = LinearPolicy.zeros(obs, act)
            rate = _rate(_iteration(rollouts, policy, sum(split)))
            walls = [wall for wall, _ in rollouts.batches]
            spare = [wall - max(r.busy_s for r in reports) for wall, reports in rollouts.batches]
            nodes_used = len(set(rollouts.nodes))
            rollouts.stop()
        rows.append(
            {
                "layout": name,
                "directions": sum(split),
                "rate": rate,
                "nodes_used": nodes_used,
                "cluster_start_s": cluster_s,
                "workers_start_s": workers_s,
                "task_ms": task_ms,
                "pipelined_task_ms": pipelined_ms,
                "iteration_ms": statistics.median(walls) * 1e3,
                "overhead_ms": statistics.median(spare) * 1e3,
            }
        )
    return rows


def ars_table() -> list[dict[str, Any]]:
    """The ARS rollouts' table: no Ray, then each Ray layout."""
    rows = local_rows() + ray_rows()
    base = next(r["rate"] for r in rows if r["layout"].startswith("Ray, 1 worker"))
    table = []
    for r in rows:
        row = {
            "layout": r["layout"],
            "directions": r["directions"],
            "env_steps_per_s": round(r["rate"]),
            "x_1_worker": round(r["rate"] / base, 2),
            "nodes": r.get("nodes_used", ""),
        }
        for key, digits in TIMES.items():
            row[key] = round(r[key], digits) if key in r else ""
        table.append(row)
    return table


def datagen_table() -> list[dict[str, Any]]:
    """The datagen table: this process, then each Ray layout on a cluster of its own."""
    frames = [local_datagen_row()]
    for name, nodes in LAYOUTS.items():
        with local_cluster(nodes) as ray:
            frames.append(_datagen_row(ray, sum(nodes), name))
    base = frames[1]["frames_per_s"]
    return [
        {
            "layout": r["layout"],
            "frames": r["frames"],
            "frames_per_s": round(r["frames_per_s"], 2),
            "x_1_worker": round(r["frames_per_s"] / base, 2),
            "nodes": r["nodes"],
            "merge_s": round(r["merge_s"], 2),
        }
        for r in frames
    ]


ARS_TITLE = "ARS rollouts of Reach-v0 on Ray (8 directions a worker, 50-step episodes)"
DATAGEN_TITLE = (
    f"datagen on Ray ({DATAGEN_SCENE.name} of apps/datagen, 640x480, COCO + BOP, "
    f"chunks of {DATAGEN_CHUNK})"
)


def run(parts: tuple[str, ...] = ("ars", "datagen")) -> dict[str, list[dict[str, Any]]]:
    """The scaling tables: ARS rollouts, datagen frames (`parts`: which)."""
    tables = {}
    if "ars" in parts:
        tables[ARS_TITLE] = ars_table()
    if "datagen" in parts:
        tables[DATAGEN_TITLE] = datagen_table()
    return tables


if __name__ == "__main__":
    from benchmarks.table import format_table
    from benchmarks.usage import exit_on_help

    exit_on_help(
        __doc__,
        "  --markdown  a Markdown table\n  --datagen   the datagen table alone\n"
        "  --ars       the ARS table alone",
    )
    chosen = tuple(p for p in ("ars", "datagen") if f"--{p}" in sys.argv)
    for title, rows in run(chosen or ("ars", "datagen")).items():
        print(f"\n{title}\n")
        print(format_table(rows, markdown="--markdown" in sys.argv))
