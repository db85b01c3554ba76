"""Perception data (issue 34): labelled frames per second at 640x480 on one core (RGB,
depth, instance and semantic segmentation, boxes, poses, keypoints, written to disk as the
native layout, COCO and BOP) against bare renders of the same frames, the first-frame
latency (a fresh process: imports, scene compile, first frame) and the memory of one worker.

Run: `python benchmarks/bench_perception.py` (prints a table); `run()` returns the rows.
Each measurement runs in a fresh process pinned to one CPU (os.sched_setaffinity), with
llvmpipe told to use one thread (LP_NUM_THREADS=1) when OSMesa renders.
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

__all__ = ["FRAMES", "ROUNDS", "run"]

FRAMES = 16
"""Frames each mode renders (after the first, timed apart)."""
ROUNDS = 3
"""Rounds of all modes (rows give the best and the median)."""


def _child(mode: str, frames: int) -> dict[str, Any]:
    """One measurement in this (fresh, pinned) process."""
    began = time.perf_counter()
    from simbridge.apps.datagen import SCENE
    from simbridge.perception import DatagenJob, FrameMaker, render_frames

    job = DatagenJob(str(SCENE), seed=0, formats=("coco", "bop"))
    with tempfile.TemporaryDirectory() as folder:
        if mode == "labelled":
            render_frames(job, [0], Path(folder))  # scene compile + first frame, written
            first = time.perf_counter() - began
            start = time.perf_counter()
            render_frames(job, range(1, frames + 1), Path(folder))
            spent = time.perf_counter() - start
        else:
            maker = FrameMaker(SCENE, seed=0)
            maker.render(maker.pose(0).views["main"], labelled=mode == "renders")
            first = time.perf_counter() - began
            start = time.perf_counter()
            for index in range(1, frames + 1):
                view = maker.pose(index).views["main"]
                maker.render(view, labelled=mode == "renders")  # rgb (+ depth, segmentation)
            spent = time.perf_counter() - start
    return {
        "fps": frames / spent,
        "first_frame_s": first,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def _measure(mode: str, frames: int) -> dict[str, Any]:
    env = dict(os.environ, LP_NUM_THREADS="1")
    env.setdefault("MUJOCO_GL", "osmesa")
    env.setdefault("PYOPENGL_PLATFORM", env["MUJOCO_GL"])
    code = (
        "import json, os, sys; os.sched_setaffinity(0, {min(os.sched_getaffinity(0))}); "
        f"sys.path.insert(0, {str(Path(__file__).resolve().parents[1])!r}); "
        "import warnings; warnings.simplefilter('ignore'); "
        "from benchmarks.bench_perception import _child; "
        f"print(json.dumps(_child({mode!r}, {frames})))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        check=False,
        env=env,
        capture_output=True,
        text=True,
        timeout=1800,
    )
    if done.returncode:
        raise RuntimeError(f"bench_perception {mode}: {done.stderr.strip()[-2000:]}")
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def run(frames: int = FRAMES, rounds: int = ROUNDS) -> list[dict[str, Any]]:
    """Rows: bare RGB renders, RGB + depth + segmentation renders, labelled and written;
    best and median of `rounds` rounds that take each mode in turn."""
    load = os.getloadavg()[0]
    modes = ("rgb", "renders", "labelled")
    results: dict[str, list[dict[str, Any]]] = {mode: [] for mode in modes}
    for _ in range(rounds):
        for mode in modes:
            results[mode].append(_measure(mode, frames))
    best = {mode: max(r["fps"] for r in results[mode]) for mode in modes}
    median = {mode: statistics.median(r["fps"] for r in results[mode]) for mode in modes}
    rows = []
    for mode, what in (
        ("rgb", "RGB render only (posed, randomised)"),
        ("renders", "RGB + depth + segmentation renders (bare)"),
        ("labelled", "labelled + written (native, COCO, BOP)"),
    ):
        rows.append({
            "mode": what,
            "fps_best": round(best[mode], 2),
            "fps_median": round(median[mode], 2),
            "cost_over_bare": (
                f"{best['renders'] / best[mode] - 1:+.0%}" if mode == "labelled" else ""
            ),
            "first_frame_s": round(min(r["first_frame_s"] for r in results[mode]), 2),
            "peak_rss_mb": round(max(r["peak_rss_mb"] for r in results[mode])),
            "load_1min": round(load, 2),
        })  # fmt: skip
    return rows


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from benchmarks.table import format_table

    print(format_table(run()))
