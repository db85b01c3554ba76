"""Frames rendered as Ray tasks, one per chunk, and stored as shards the driver merges.

A task renders its chunk into a folder of its own on whatever node runs it and returns
the folder's files through the object store, so the nodes need no shared filesystem.
The driver stores each shard under `shards/` atomically (written beside, then renamed),
so a shard is there whole or not at all. A task whose worker dies is retried by Ray
(`max_retries`); rendering is a pure function of the frame indices, so the retry's
shard is the one the lost attempt would have given, and the driver stores the first
copy of each shard only: no duplicates, no holes. A progress board (a Ray actor) holds
each chunk's frames done in its latest attempt, so progress counts every node's work and
a retried chunk starts again from zero instead of counting twice.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from simbridge.cluster.runtime import node_id
from simbridge.errors import ClusterError

__all__ = [
    "MAX_RETRIES",
    "Progress",
    "ProgressBoard",
    "RenderChunk",
    "Shard",
    "ShardRun",
    "chunks",
    "render_on_ray",
    "shard_name",
    "store_shard",
]

MAX_RETRIES = 3
"""Times Ray runs a chunk again after its worker died (node lost, process killed)."""

RenderChunk = Callable[[range, Path, Callable[[int], None]], object]
"""Renders frames `range` into an empty folder, calling back with the frames done."""


def chunks(frames: int, size: int, first: int = 0) -> list[range]:
    """Frames first .. first + frames - 1 in consecutive ranges of `size` (the last may be
    shorter)."""
    if size < 1:
        raise ClusterError(f"chunk size must be >= 1, got {size}")
    end = first + frames
    return [range(lo, min(lo + size, end)) for lo in range(first, end, size)]


@dataclass(frozen=True)
class Shard:
    """One chunk's output: its files (path in the shard -> bytes), and where it ran."""

    index: int
    frames: range
    files: dict[str, bytes]
    node: str
    pid: int


@dataclass
class Progress:
    """Frames done across the cluster: in total, and per node (latest attempts)."""

    done: int
    total: int
    per_node: dict[str, int]
    attempts: dict[int, list[int]]
    """Per chunk, the worker processes that ran it (more than one: retried)."""
    running: dict[int, tuple[int, int]]
    """Chunks under way -> the worker process of their latest attempt, its frames done."""
    rendered_per_node: dict[str, int] = field(default_factory=dict)
    """Frames each node rendered, lost attempts included (what the cluster worked)."""


class ProgressBoard:
    """The Ray actor tasks report to: each chunk's latest attempt, its node and its
    frames done."""

    def __init__(self, sizes: Sequence[int]) -> None:
        self.sizes = list(sizes)
        self.latest: dict[int, tuple[int, str, int]] = {}  # chunk -> (pid, node, done)
        self.attempts: dict[int, list[int]] = {}
        self.rendered: dict[tuple[int, int], tuple[str, int]] = {}  # (chunk, pid) -> node, done
        self.finished: set[int] = set()

    def report(self, chunk: int, pid: int, node: str, done: int) -> None:
        """Chunk `chunk`'s attempt in process `pid` on `node` has `done` frames."""
        seen = self.attempts.setdefault(chunk, [])
        if pid not in seen:
            seen.append(pid)
        self.latest[chunk] = (pid, node, done)
        self.rendered[chunk, pid] = (node, done)

    def finish(self, chunk: int, pid: int, node: str) -> None:
        """The driver stored chunk `chunk`, which process `pid` on `node` rendered."""
        self.finished.add(chunk)
        self.latest[chunk] = (pid, node, self.sizes[chunk])

    def progress(self) -> Progress:
        """What the board knows now."""
        per_node: dict[str, int] = {}
        for _, node, done in self.latest.values():
            per_node[node] = per_node.get(node, 0) + done
        running = {
            chunk: (pid, done)
            for chunk, (pid, _, done) in self.latest.items()
            if chunk not in self.finished
        }
        rendered: dict[str, int] = {}
        for node, done in self.rendered.values():
            rendered[node] = rendered.get(node, 0) + done
        return Progress(
            sum(per_node.values()),
            sum(self.sizes),
            per_node,
            {chunk: list(pids) for chunk, pids in self.attempts.items()},
            running,
            rendered,
        )


def _render_chunk(render: RenderChunk, index: int, frames: range, board: Any) -> Shard:
    """The task: render into a temporary folder on this node, return its files."""
    pid, node = os.getpid(), node_id()

    def report(done: int) -> None:
        board.report.remote(index, pid, node, done)

    report(0)
    with tempfile.TemporaryDirectory(prefix="simbridge-shard-") as folder:
        root = Path(folder)
        render(frames, root, report)
        files = {
            path.relative_to(root).as_posix(): path.read_bytes()
            for path in sorted(root.rglob("*"))
            if path.is_file()
        }
    return Shard(index, frames, files, node, pid)


def shard_name(frames: range) -> str:
    """The folder name of the shard of `frames` (by its frames, so a run started again
    with the same chunks finds the shards already stored)."""
    return f"shard-{frames.start:06d}-{frames.stop:06d}"


def store_shard(shard: Shard, root: Path) -> Path:
    """Write `shard` to root/shard-FIRST-STOP atomically (a sibling folder renamed into
    place); a shard already stored stays as it is."""
    final = root / shard_name(shard.frames)
    if final.exists():
        return final
    partial = root / f".{final.name}.partial"
    shutil.rmtree(partial, ignore_errors=True)  # left by a driver that died mid-write
    for name, data in shard.files.items():
        path = partial / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    partial.mkdir(parents=True, exist_ok=True)  # an empty shard is a folder too
    os.rename(partial, final)
    return final


@dataclass
class ShardRun:
    """Where the shards of a run are and where their work ran."""

    shards: list[Path]
    nodes: dict[int, str] = field(default_factory=dict)
    """Per chunk, the node whose shard was stored."""
    progress: Progress | None = None
    wall_s: float = 0.0


def render_on_ray(
    ray: Any,
    render: RenderChunk,
    ranges: Sequence[range],
    root: Path,
    *,
    progress: Callable[[Progress], None] | None = None,
    every_s: float = 1.0,
) -> ShardRun:
    """Render `ranges` as one Ray task each (one CPU, retried when its worker dies) into
    shards under `root`, calling `progress` about every `every_s` seconds. Chunks whose
    shard is already under `root` are not rendered again."""
    start = time.perf_counter()
    root.mkdir(parents=True, exist_ok=True)
    board = ray.remote(num_cpus=0)(ProgressBoard).remote([len(frames) for frames in ranges])
    task = ray.remote(num_cpus=1, max_retries=MAX_RETRIES)(_render_chunk)
    run = ShardRun([root / shard_name(frames) for frames in ranges])
    pending = {
        task.remote(render, index, frames, board): index
        for index, frames in enumerate(ranges)
        if not (root / shard_name(frames)).exists()
    }
    last = time.perf_counter()
    try:
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=every_s)
            for ref in ready:
                index = pending.pop(ref)
                try:
                    shard: Shard = ray.get(ref)
                except ray.exceptions.RayError as exc:
                    raise ClusterError(f"chunk {index} ({ranges[index]}) failed: {exc}") from exc
                store_shard(shard, root)
                run.nodes[index] = shard.node
                ray.get(board.finish.remote(index, shard.pid, shard.node))
            if progress is not None and (not pending or time.perf_counter() - last >= every_s):
                last = time.perf_counter()
                progress(ray.get(board.progress.remote()))
        run.progress = ray.get(board.progress.remote())
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)
        ray.kill(board)
    run.wall_s = time.perf_counter() - start
    return run
