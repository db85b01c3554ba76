"""Work on a real two-node Ray cluster (`ray.cluster_utils.Cluster`, one CPU a node): it
runs on both nodes and gives what the single-process path gives."""

from __future__ import annotations

import functools
import hashlib
import json
import os
import signal
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from simbridge.cli import main
from simbridge.cluster import train_ars_on_ray
from simbridge.cluster.datagen import RUN_RECORD, SHARDS, datagen_on_ray
from simbridge.cluster.shards import Progress, chunks, render_on_ray
from simbridge.errors import ClusterError
from simbridge.gym import ARSConfig, train_ars
from simbridge.gym.ars import CurvePoint
from simbridge.perception import DatagenJob, generate, merge_shards, render_frames
from tests.perception.scenes import random_scene
from tests.raysupport import descendants_named, local_cluster, require_ray

ENV_ID = "simbridge/Reach-v0"
DATAGEN_FRAMES = 8
DATAGEN_CHUNK = 4


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
        f"shard-{i // 4 * 4:06d}-{i // 4 * 4 + 4:06d}/{i:05d}.txt" for i in range(12)
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


def _hashes(root: Path) -> dict[str, str]:
    return {
        path.relative_to(root).as_posix(): hashlib.sha256(path.read_bytes()).hexdigest()
        for path in sorted(root.rglob("*"))
        if path.is_file()
    }


@pytest.fixture(scope="module")
def datagen_job(tmp_path_factory: pytest.TempPathFactory) -> DatagenJob:
    """A small randomised scene (64x48) as a dataset job, shared by the module's tests
    (a Ray worker builds its scene once and keeps it for every chunk of the same job)."""
    scene = random_scene(tmp_path_factory.mktemp("scene"))
    return DatagenJob(str(scene), seed=11, formats=("coco", "bop"))


@pytest.fixture(scope="module")
def local_dataset(datagen_job: DatagenJob, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """DATAGEN_FRAMES frames of the job made by one process, without Ray."""
    out = tmp_path_factory.mktemp("local") / "dataset"
    generate(datagen_job, DATAGEN_FRAMES, out)
    return out


def test_datagen_ray_cli_on_two_nodes_writes_the_single_process_bytes(
    cluster: Any, datagen_job: DatagenJob, local_dataset: Path, tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:  # fmt: skip
    out = tmp_path / "ray"
    assert main(["datagen", datagen_job.scene, "--frames", str(DATAGEN_FRAMES), "--out",
                 str(out), "--seed", "11", "--ray", "auto", "--chunk", "2"]) == 0  # fmt: skip
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert f"datagen: {DATAGEN_FRAMES} frames ({DATAGEN_FRAMES} rendered now on Ray in 4 " in line
    # the dataset is the one-process dataset byte for byte, no shard folder left; the
    # run's record is the one file beside it
    ray_files = _hashes(out)
    record = json.loads((out / RUN_RECORD).read_text())
    del ray_files[RUN_RECORD]
    assert ray_files == _hashes(local_dataset)
    # where it ran: both nodes, every chunk once in the record, every frame counted once
    assert set(record["nodes"]) == _alive_nodes()
    assert [c["frames"] for c in record["chunks"]] == [[0, 2], [2, 4], [4, 6], [6, 8]]
    assert {c["node"] for c in record["chunks"]} == _alive_nodes()
    assert sum(record["frames_per_node"].values()) == DATAGEN_FRAMES
    # a second run into the same folder is refused rather than mixed in
    with pytest.raises(ClusterError, match="already holds a dataset"):
        datagen_on_ray(datagen_job, DATAGEN_FRAMES, out)


STALLED_CHUNK = 1
"""The chunk whose first attempt stops after one frame, until the test kills it."""


def _render_stalling_once(
    job: DatagenJob, marks: Path, frames: range, folder: Path, report: Callable[[int], None]
) -> None:
    """`render_frames`, except that chunk STALLED_CHUNK's first attempt (the first to
    create its mark) waits after its first frame, long enough to be killed there."""
    first = False
    if frames.start == STALLED_CHUNK * DATAGEN_CHUNK:
        try:
            (marks / "stalled").touch(exist_ok=False)
            first = True
        except FileExistsError:
            pass

    def stall_after_one(done: int) -> None:
        report(done)
        if first and done == 1:
            time.sleep(300)  # the test kills this process within a second or so

    render_frames(job, frames, folder, stall_after_one)


def test_datagen_chunk_killed_mid_render_is_retried_without_duplicates_or_holes(
    cluster: Any, datagen_job: DatagenJob, local_dataset: Path, tmp_path: Path
) -> None:
    ray = require_ray()
    killed: list[int] = []
    seen: list[Progress] = []

    def kill_the_stalled_chunk(progress: Progress) -> None:
        seen.append(progress)
        pid, done = progress.running.get(STALLED_CHUNK, (0, 0))
        if not killed and done == 1:
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

    marks = tmp_path / "marks"
    marks.mkdir()
    render = functools.partial(_render_stalling_once, datagen_job, marks)
    ranges = chunks(DATAGEN_FRAMES, DATAGEN_CHUNK)
    run = render_on_ray(
        ray, render, ranges, tmp_path / "shards", progress=kill_the_stalled_chunk, every_s=0.2
    )
    merge_shards(datagen_job, run.shards, tmp_path / "ray", DATAGEN_FRAMES)
    assert killed, "the stalled chunk was never seen one frame in"
    assert run.progress is not None
    assert run.progress.attempts[STALLED_CHUNK][0] == killed[0]
    assert len(run.progress.attempts[STALLED_CHUNK]) == 2  # retried in another process
    # no frame twice, none missing: the one-process dataset, byte for byte
    assert _hashes(tmp_path / "ray") == _hashes(local_dataset)
    # progress ended at every frame once, though the killed attempt rendered one more
    assert seen[-1].done == seen[-1].total == DATAGEN_FRAMES
    assert sum(seen[-1].rendered_per_node.values()) == DATAGEN_FRAMES + 1


def test_datagen_on_ray_resumes_a_dataset_and_the_shards_of_an_interrupted_run(
    cluster: Any, datagen_job: DatagenJob, local_dataset: Path, tmp_path: Path
) -> None:
    out = tmp_path / "resumed"
    generate(datagen_job, 2, out)  # frames 0-1 merged, as by a run cut short
    # a shard an interrupted Ray run stored (frames 4-5), not merged yet
    render_frames(datagen_job, range(4, 6), out / SHARDS / "shard-000004-000006")
    other = DatagenJob(datagen_job.scene, seed=12, formats=datagen_job.formats)
    with pytest.raises(ClusterError, match="another scene, seed"):
        datagen_on_ray(other, DATAGEN_FRAMES, out, resume=True)
    made = datagen_on_ray(datagen_job, DATAGEN_FRAMES, out, chunk_frames=2, resume=True)
    # chunks from frame 2 on; the stored shard's chunk was not sent to the cluster
    assert made.first_frame == 2
    chunk_rows = made.record["chunks"]
    assert [c["frames"] for c in chunk_rows] == [[2, 4], [4, 6], [6, 8]]
    assert [c["attempts"] for c in chunk_rows] == [1, 0, 1]
    assert chunk_rows[1]["node"] is None
    resumed = _hashes(out)
    del resumed[RUN_RECORD]
    assert resumed == _hashes(local_dataset)
