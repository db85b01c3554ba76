"""Perception data (issue 34): labelled frames per second at 640x480 on one core (RGB,
depth, instance and semantic segmentation, boxes, poses, keypoints, written to disk as the
native layout, COCO and BOP) against bare renders of the same frames, the first-frame
latency (a fresh process: imports, scene compile, first frame) and the memory of one worker.

A second table splits a labelled frame's CPU time (the process's, llvmpipe's thread
included: robust to other processes' load) by stage, and gives the most frames/s one core
can render (1 / the renders' CPU time) and label and write (1 / all stages').

Run: `python benchmarks/bench_perception.py` (prints the tables); `run()` returns them.
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

__all__ = ["FRAMES", "ROUNDS", "run", "stage_rows"]

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


def _stages(frames: int) -> dict[str, Any]:
    """CPU seconds (the whole process's) per labelled frame, by stage, after a first frame."""
    from simbridge.apps.datagen import SCENE
    from simbridge.perception import FrameMaker
    from simbridge.perception.bop import write_bop_frame
    from simbridge.perception.native import frame_json_path, json_bytes, write_atomic, write_native

    maker = FrameMaker(SCENE, seed=0)
    output = maker.config.output
    cost = {"pose (randomisers, mj_forward)": 0.0, "make (pose, renders, labels)": 0.0}
    cost["write (native, BOP)"] = 0.0
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        maker.make(0)
        before = dict(maker.render_times().seconds)
        for index in range(1, frames + 1):
            clock = time.process_time()
            maker.pose(index)  # timed alone; make() poses again
            cost["pose (randomisers, mj_forward)"] += time.process_time() - clock
            clock = time.process_time()
            frame = maker.make(index)
            cost["make (pose, renders, labels)"] += time.process_time() - clock
            clock = time.process_time()
            record, pngs = write_native(folder, frame, output.png_compression)
            write_bop_frame(folder, frame, pngs, output.depth_scale, output.png_compression)
            write_atomic(frame_json_path(folder, index), json_bytes(record))
            cost["write (native, BOP)"] += time.process_time() - clock
    render = {k: v - before.get(k, 0.0) for k, v in maker.render_times().seconds.items()}
    labels = cost.pop("make (pose, renders, labels)") - sum(render.values())
    labels -= cost["pose (randomisers, mj_forward)"]
    stages = {**render, "labels (annotate, image steps)": labels, **cost}
    return {"ms": {k: 1000 * v / frames for k, v in stages.items()}, "renders": list(render)}


def _measure(mode: str, frames: int) -> dict[str, Any]:
    env = dict(os.environ, LP_NUM_THREADS="1")
    env.setdefault("MUJOCO_GL", "osmesa")
    env.setdefault("PYOPENGL_PLATFORM", env["MUJOCO_GL"])
    code = (
        "import json, os, sys; os.sched_setaffinity(0, {min(os.sched_getaffinity(0))}); "
        f"sys.path.insert(0, {str(Path(__file__).resolve().parents[1])!r}); "
        "import warnings; warnings.simplefilter('ignore'); "
        "from benchmarks.bench_perception import _child, _stages; "
        f"mode, frames = {mode!r}, {frames}; "
        "print(json.dumps(_stages(frames) if mode == 'stages' else _child(mode, frames)))"
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


def stage_rows(frames: int = FRAMES, rounds: int = ROUNDS) -> list[dict[str, Any]]:
    """CPU ms per labelled frame by stage (median and least of `rounds` fresh processes),
    then the renders' sum and all stages' sum with the frames/s each allows one core."""
    results = [_measure("stages", frames) for _ in range(rounds)]
    load = round(os.getloadavg()[0], 2)
    renders = set(results[0]["renders"])
    rows, sums = [], {"renders": [0.0] * rounds, "all": [0.0] * rounds}
    for stage in results[0]["ms"]:
        values = [r["ms"][stage] for r in results]
        for k, value in enumerate(values):
            sums["all"][k] += value
            if stage in renders:
                sums["renders"][k] += value
        rows.append({
            "stage": ("render: " if stage in renders else "") + stage,
            "cpu_ms_median": round(statistics.median(values), 1),
            "cpu_ms_least": round(min(values), 1),
            "frames_per_s_bound": "",
            "load_1min": load,
        })  # fmt: skip
    for key, what in (("renders", "sum of the renders"), ("all", "sum of all stages")):
        least = min(sums[key])
        rows.append({
            "stage": what,
            "cpu_ms_median": round(statistics.median(sums[key]), 1),
            "cpu_ms_least": round(least, 1),
            "frames_per_s_bound": round(1000 / least, 2),
            "load_1min": load,
        })  # fmt: skip
    return rows


def run(frames: int = FRAMES, rounds: int = ROUNDS) -> dict[str, list[dict[str, Any]]]:
    """Two tables: frames/s of bare RGB renders, RGB + depth + segmentation renders, and
    labelled and written frames (best and median of `rounds` rounds that take each mode in
    turn); and `stage_rows`."""
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
    return {
        "Perception: frames/s on one core": rows,
        "Perception: CPU per labelled frame, by stage": stage_rows(frames, rounds),
    }


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from benchmarks.table import format_table

    for title, table in run().items():
        print(f"{title}\n\n{format_table(table)}\n")
