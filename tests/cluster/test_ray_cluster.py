"""Work on a real two-node Ray cluster (`ray.cluster_utils.Cluster`, one CPU a node): it
runs on both nodes and gives what the single-process path gives."""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from simbridge.cluster import train_ars_on_ray
from simbridge.cluster.shards import Progress, chunks, render_on_ray
from simbridge.gym import ARSConfig, train_ars
from simbridge.gym.ars import CurvePoint
from tests.raysupport import descendants_named, local_cluster, require_ray

ENV_ID = "simbridge/Reach-v0"


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    require_ray()
    with local_cluster(nodes=2) as running:
        yield running


def _alive_nodes() -> set[str]:
    ray = require_ray()
    return {node["NodeID"] for node in ray.nodes() if node["Alive"]}


def test_ars_on_two_nodes_learns_what_the_local_learner_learns_through_a_killed_worker(
    cluster: Any,
) -> None:
    # 3 directions on 2 workers: shares of 2 and 1, so the join has work to do
    config = ARSConfig(
        directions=3, top=2, iterations=3, eval_every=2, eval_episodes=5, target_success=None
    )
    killed: list[int] = []

    def kill_a_worker(point: CurvePoint) -> None:  # after the first evaluation
        if not killed:
            workers = descendants_named("ray::RolloutWorker")
            assert len(workers) == 2, workers
            os.kill(workers[0], signal.SIGKILL)
            killed.append(workers[0])

    run = train_ars_on_ray(ENV_ID, 20, config, workers=2, progress=kill_a_worker)
    vec = gym.make_vec(ENV_ID, num_envs=2 * config.directions, max_episode_steps=20)
    local = train_ars(vec, 20, config)
    vec.close()
    # where it ran: one worker on each node (one CPU each), both reported episodes; the
    # killed one was replaced (on its node: the other's CPU is taken)
    assert killed
    assert run.restarts == 1
    assert len(set(run.worker_nodes)) == 2
    assert set(run.worker_nodes) == _alive_nodes()
    assert set(run.episodes_per_node) == set(run.worker_nodes)
    iterations, pairs = config.iterations, 2 * config.directions
    evaluations = len(local.curve) * config.eval_episodes
    assert sum(run.episodes_per_node.values()) == iterations * pairs + evaluations
    # what it learned: bit for bit the local learner's (same machine, same seed)
    ray_curve = [
        (p.iteration, p.env_steps, p.mean_return, p.success_rate) for p in run.result.curve
    ]
    local_curve = [(p.iteration, p.env_steps, p.mean_return, p.success_rate) for p in local.curve]
    assert ray_curve == local_curve
    np.testing.assert_array_equal(run.result.policy.weights, local.policy.weights)
    np.testing.assert_array_equal(run.result.policy.mean, local.policy.mean)
    np.testing.assert_array_equal(run.result.policy.var, local.policy.var)
    assert np.any(run.result.policy.weights != 0)


def test_docs_python_example_runs_on_the_cluster(cluster: Any) -> None:
    from tests.cluster.test_ray_docs import example

    namespace: dict[str, Any] = {}
    exec(compile(example("python", "python"), "docs/ray.md", "exec"), namespace)
    run = namespace["run"]
    assert set(run.worker_nodes) == _alive_nodes()
    assert [point.iteration for point in run.result.curve] == [0, 5]
    assert sum(run.episodes_per_node.values()) == 5 * 16 + 2 * 32


def _render_text(frames: range, folder: Path, report: Callable[[int], None]) -> None:
    """A stand-in chunk renderer: one file per frame, a pure function of its index."""
    for done, frame in enumerate(frames, 1):
        time.sleep(0.2)  # long enough for the test to kill a chunk under way
        (folder / f"{frame:05d}.txt").write_text(f"frame {frame}\n" * (frame + 1))
        report(done)


def test_shards_survive_a_killed_worker_without_duplicates_or_holes(
    cluster: Any, tmp_path: Path
) -> None:
    ray = require_ray()
    killed: list[int] = []
    seen: list[Progress] = []

    def kill_a_chunk_under_way(progress: Progress) -> None:
        seen.append(progress)
        # a chunk with a frame or two done of its 4 (so at least 2 x 0.2 s still to go)
        started = [(c, pid) for c, (pid, done) in progress.running.items() if 0 < done <= 2]
        if not killed and started:
            chunk, pid = started[0]
            os.kill(pid, signal.SIGKILL)
            killed.append(chunk)

    ranges = chunks(12, 4)
    run = render_on_ray(
        ray, _render_text, ranges, tmp_path / "shards", progress=kill_a_chunk_under_way, every_s=0.2
    )
    assert killed, "no chunk was under way to kill"
    assert run.progress is not None
    assert len(run.progress.attempts[killed[0]]) == 2  # retried in another process
    # every frame once, in the shard of its chunk, as the renderer writes it
    written = sorted((tmp_path / "shards").rglob("*.txt"))
    assert [p.relative_to(tmp_path / "shards").as_posix() for p in written] == [
        f"shard-{i // 4:05d}/{i:05d}.txt" for i in range(12)
    ]
    assert all(p.read_text() == f"frame {int(p.stem)}\n" * (int(p.stem) + 1) for p in written)
    assert not list((tmp_path / "shards").glob(".*")), "a partial shard was left"
    # progress counted across both nodes, ending at every frame once; both nodes rendered
    # (the killed attempt's frames count as work, not as progress; a chunk waiting for the
    # busy head is sent to the other node)
    assert set(run.nodes.values()) <= _alive_nodes()
    assert seen[-1].done == seen[-1].total == 12
    assert set(seen[-1].rendered_per_node) == _alive_nodes()
    assert sum(seen[-1].rendered_per_node.values()) > 12
