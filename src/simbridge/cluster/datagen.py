"""`simbridge datagen --ray`: a perception dataset rendered as Ray tasks, one per chunk of
frames, merged by the driver into the dataset one process would have written.

Frames are pure functions of (seed, frame index) (`simbridge.perception.dataset`), so
the chunks can run anywhere in any order: `simbridge.cluster.shards` renders each into a
shard (retried when its worker dies, stored atomically under OUT/.ray-shards), and
`merge_shards` gathers the shards into OUT and writes the dataset-wide files. The shard
folder goes once the merge is done; the dataset is then byte for byte `generate`'s, and
OUT/ray-run.json (beside it, not part of it) records where each chunk ran.
"""

from __future__ import annotations

import functools
import json
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from simbridge.cluster.runtime import connect
from simbridge.cluster.shards import Progress, ShardRun, chunks, render_on_ray
from simbridge.errors import ClusterError
from simbridge.perception.dataset import (
    DatagenJob,
    DatasetSummary,
    first_missing_frame,
    merge_shards,
    render_frames,
)

__all__ = ["CHUNK_FRAMES", "RUN_RECORD", "SHARDS", "RayDataset", "datagen_on_ray"]

CHUNK_FRAMES = 25
"""Frames per task by default: seconds of rendering, against a task overhead of ms."""

SHARDS = ".ray-shards"
"""The folder in OUT where shards wait for the merge (kept by an interrupted run)."""

RUN_RECORD = "ray-run.json"
"""The run's record in OUT: the chunks, the node and processes each ran on, per-node
frames (the one file a Ray run writes beyond the dataset)."""

META = Path("native") / "dataset.json"
"""The file that says OUT holds a dataset, and of which job (`simbridge.perception`)."""


@dataclass(frozen=True)
class RayDataset:
    """A dataset made on a cluster: what the merge wrote, and where the chunks ran."""

    summary: DatasetSummary
    run: ShardRun
    chunk_frames: int
    first_frame: int
    """Where this run started (above 0 when it resumed a dataset)."""
    record: dict[str, Any]
    """What OUT/ray-run.json holds."""


def _check_resumable(job: DatagenJob, out: Path) -> None:
    """ClusterError unless the dataset in `out` and the shards an interrupted run stored
    are `job`'s (scene, seed, formats, labelers): their metadata must be what rendering no
    frame of `job` writes."""
    found = [out / META, *sorted((out / SHARDS).glob(f"shard-*/{META.as_posix()}"))]
    found = [path for path in found if path.exists()]
    if not found:
        return
    with tempfile.TemporaryDirectory(prefix="simbridge-meta-") as folder:
        render_frames(job, [], Path(folder))
        expected = (Path(folder) / META).read_bytes()
    for path in found:
        if path.read_bytes() != expected:
            raise ClusterError(
                f"'{path}' is the metadata of a dataset of another scene, seed, format or "
                "labeler set; it cannot be resumed with these options"
            )


def _record(
    job: DatagenJob, frames: int, ranges: list[range], run: ShardRun, *, start: int, address: str
) -> dict[str, Any]:
    """The run's record: per chunk its frames, the node whose shard was kept and the
    worker processes that ran it; per node the frames it rendered."""
    progress = run.progress
    attempts = progress.attempts if progress is not None else {}
    chunk_rows = [
        {
            "frames": [r.start, r.stop],
            "node": run.nodes.get(i),
            "attempts": len(attempts.get(i, [])),
        }
        for i, r in enumerate(ranges)
    ]
    return {
        "ray": address,
        "scene": job.scene,
        "seed": job.seed,
        "frames": frames,
        "first_frame": start,
        "nodes": sorted(set(run.nodes.values())),
        "frames_per_node": dict(sorted(progress.per_node.items())) if progress else {},
        "rendered_per_node": dict(sorted(progress.rendered_per_node.items())) if progress else {},
        "chunks": chunk_rows,
        "wall_s": round(run.wall_s, 3),
    }


def datagen_on_ray(
    job: DatagenJob,
    frames: int,
    out: Path,
    *,
    address: str = "auto",
    chunk_frames: int = CHUNK_FRAMES,
    resume: bool = False,
    progress: Callable[[Progress], None] | None = None,
    every_s: float = 1.0,
) -> RayDataset:
    """Render frames 0 .. frames - 1 of `job` on the cluster at `address` into `out`, in
    tasks of `chunk_frames`, calling `progress` about every `every_s` seconds; `resume`
    continues a dataset of the same job (merged frames are kept, and shards an
    interrupted run stored are not rendered again)."""
    if frames < 1:
        raise ClusterError(f"--frames must be >= 1, got {frames}")
    if chunk_frames < 1:
        raise ClusterError(f"--chunk must be >= 1, got {chunk_frames}")
    out = Path(out)
    root = out / SHARDS
    if not resume and (root.exists() or (out / META).exists()):
        raise ClusterError(
            f"'{out}' already holds a dataset or the shards of an interrupted run; pass "
            "--resume to continue it or choose another folder"
        )
    if resume:
        _check_resumable(job, out)
    start = first_missing_frame(out, frames)
    ranges = chunks(frames - start, chunk_frames, first=start)
    render = functools.partial(render_frames, job)
    with connect(address) as ray:
        run = render_on_ray(ray, render, ranges, root, progress=progress, every_s=every_s)
    summary = merge_shards(job, [*run.shards, out], out, frames)
    shutil.rmtree(root)
    record = _record(job, frames, ranges, run, start=start, address=address)
    (out / RUN_RECORD).write_text(json.dumps(record, indent=2) + "\n")
    return RayDataset(summary, run, chunk_frames, start, record)
