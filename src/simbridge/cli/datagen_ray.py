"""`simbridge datagen ... --ray ADDRESS`: the dataset rendered as Ray tasks across a
cluster (simbridge.cluster.datagen), with the cluster's progress per node on stderr and a
summary line naming the nodes that rendered."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

__all__ = ["run_datagen_on_ray"]


def run_datagen_on_ray(
    scene: Path,
    frames: int,
    out: Path,
    *,
    formats: tuple[str, ...],
    seed: int,
    resume: bool,
    address: str,
    chunk: int | None,
    quality: str | None = None,
) -> int:
    """Make the dataset on the cluster at `address` in tasks of `chunk` frames (None: the
    default, CHUNK_FRAMES), with a status line on stderr, and print a summary line."""
    from simbridge.cluster.datagen import CHUNK_FRAMES, RUN_RECORD, datagen_on_ray
    from simbridge.cluster.shards import Progress
    from simbridge.perception import DatagenJob
    from simbridge.progress import Ticker, elapsed

    job = DatagenJob(str(scene), seed=seed, formats=formats, quality=quality)
    chunk = CHUNK_FRAMES if chunk is None else chunk
    latest: list[Progress] = []
    began = time.perf_counter()

    def status() -> str:
        if not latest:
            waited = elapsed(time.perf_counter() - began)
            return f"datagen on Ray ({address}): starting the tasks, {waited}"
        now = latest[0]
        spent = time.perf_counter() - began
        rate = now.done / spent if spent > 0 else 0.0
        left = f", {elapsed((now.total - now.done) / rate)} left" if rate > 0 else ""
        nodes = ", ".join(f"{node[:8]} {count}" for node, count in sorted(now.per_node.items()))
        return (
            f"datagen on Ray: {now.done}/{now.total} frames, {len(now.running)} chunks "
            f"running, {len(now.per_node)} node(s) [{nodes}] ({rate:.1f} frames/s{left})"
        )

    def show(progress: Progress) -> None:
        latest[:] = [progress]

    with Ticker(status, every=1.0, plain_every=1.0):
        made = datagen_on_ray(
            job, frames, out, address=address, chunk_frames=chunk, resume=resume, progress=show
        )
    wall = time.perf_counter() - began
    todo = frames - made.first_frame
    record: dict[str, Any] = made.record
    per_node = ", ".join(f"{n[:8]} {c}" for n, c in record["frames_per_node"].items())
    summary = made.summary
    print(
        f"datagen: {summary.frames} frames ({todo} rendered now on Ray in "
        f"{len(made.run.shards)} chunks of {chunk}, {len(record['nodes'])} node(s): "
        f"{per_node or 'none'}), {summary.images} images, {summary.annotations} COCO "
        f"annotations, {summary.instances} labelled instances of {scene.name} seed {seed} "
        f"-> {out}/ (where it ran: {out / RUN_RECORD}) in {elapsed(wall)}"
    )
    return 0
