"""Perception data (issue 34): labelled frames per second at 640x480 on one core (RGB,
depth, instance and semantic segmentation, boxes, poses, keypoints, written to disk as the
native layout, COCO and BOP; and the native layout alone: RGB PNG, an NPZ of depth,
instance and semantic images, a JSON of boxes and poses) against bare renders of the same
frames, the first-frame latency (a fresh process: imports, scene compile, first frame) and
the memory of one worker, at each render quality (`fast`: the shipped datagen scene's;
`balanced`: shadows from a 2048 map; `high`: shadows and 4x MSAA).

A second table splits a labelled frame's CPU time (the process's, llvmpipe's thread
included: robust to other processes' load) by stage, and gives the most frames/s one core
can render (1 / the renders' CPU time) and label and write (1 / all stages'), and what
labelling and writing cost over the bare renders (pose and renders) of the same frames,
and over the frames (pose, renders and the image randomisers: background and noise),
with every format and with the native layout alone.

Rows give the best, the median and a 95% interval of the median over 6 rounds.

Run: `python benchmarks/bench_perception.py [--quick] [--markdown]` (prints the tables;
`--quick`: 2 frames, 1 round, `fast` only, all modes in one process: a check that it
runs, not a measurement); `run()` returns them.
Each measurement runs in a fresh process pinned to one CPU (os.sched_setaffinity), with
llvmpipe told to use one thread (LP_NUM_THREADS=1) when OSMesa renders.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # also as a bare script

from benchmarks.repeats import median_interval

__all__ = ["FRAMES", "MODES", "QUALITIES", "ROUNDS", "run", "stage_rows"]

FRAMES = 16
"""Frames each mode renders (after the first, timed apart)."""
ROUNDS = 6
"""Rounds of all modes (rows give the best, the median and a 95% interval of the median:
from 6 rounds, the lowest and highest round)."""
QUALITIES = ("fast", "balanced", "high")
"""Render presets measured (simbridge.perception.render.QUALITIES)."""


def _child(mode: str, frames: int, quality: str) -> dict[str, Any]:
    """One measurement in this (fresh, pinned) process."""
    began = time.perf_counter()
    from benchmarks.procstatus import proc_status
    from simbridge.apps.datagen import SCENE
    from simbridge.perception import DatagenJob, FrameMaker, render_frames

    formats = ("coco", "bop") if mode == "labelled" else ()
    job = DatagenJob(str(SCENE), seed=0, formats=formats, quality=quality)
    with tempfile.TemporaryDirectory() as folder:
        if mode in ("labelled", "native"):
            render_frames(job, [0], Path(folder))  # scene compile + first frame, written
            first = time.perf_counter() - began
            start = time.perf_counter()
            render_frames(job, range(1, frames + 1), Path(folder))
            spent = time.perf_counter() - start
        else:
            maker = FrameMaker(SCENE, seed=0, quality=quality)
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
        # VmHWM, not ru_maxrss: Linux carries the peak of the process this one was spawned
        # from (make bench's, grown by the suites before: 2.6 GB) across exec into ru_maxrss.
        "peak_rss_mb": proc_status("VmHWM") / 2**20,
    }


WRITE_NATIVE = "write: native (RGB PNG, NPZ of depth and label images, JSON)"
WRITE_BOP = "write: BOP (its RGB, 16-bit depth PNG, two masks an instance)"


def _stages(frames: int, quality: str) -> dict[str, Any]:
    """CPU seconds (the whole process's) per labelled frame, by stage, after a first frame."""
    from simbridge.apps.datagen import SCENE
    from simbridge.perception import FrameMaker
    from simbridge.perception.bop import write_bop_frame
    from simbridge.perception.frames import IMAGE_STEPS
    from simbridge.perception.native import frame_json_path, json_bytes, write_atomic, write_native

    maker = FrameMaker(SCENE, seed=0, quality=quality)
    output = maker.config.output
    cost = {"pose (randomisers, mj_forward)": 0.0, "make (pose, renders, labels)": 0.0}
    cost[WRITE_NATIVE] = cost[WRITE_BOP] = 0.0
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
            write_atomic(frame_json_path(folder, index), json_bytes(record))
            cost[WRITE_NATIVE] += time.process_time() - clock
            clock = time.process_time()
            write_bop_frame(folder, frame, pngs, output.depth_scale, output.png_compression)
            cost[WRITE_BOP] += time.process_time() - clock
    render = {k: v - before.get(k, 0.0) for k, v in maker.render_times().seconds.items()}
    image = render.pop(IMAGE_STEPS, 0.0)
    labels = cost.pop("make (pose, renders, labels)") - sum(render.values()) - image
    labels -= cost["pose (randomisers, mj_forward)"]
    stages = {**render, IMAGE_STEPS: image, "labels (annotate)": labels, **cost}
    return {
        "ms": {k: 1000 * v / frames for k, v in stages.items()},
        "renders": list(render),
        "image": IMAGE_STEPS,
    }


def _measure(modes: tuple[str, ...], frames: int, quality: str) -> list[dict[str, Any]]:
    """Each mode measured in turn in one fresh, pinned process."""
    env = dict(os.environ, LP_NUM_THREADS="1")
    env.setdefault("MUJOCO_GL", "osmesa")
    env.setdefault("PYOPENGL_PLATFORM", env["MUJOCO_GL"])
    code = (
        "import json, os, sys; os.sched_setaffinity(0, {min(os.sched_getaffinity(0))}); "
        f"sys.path.insert(0, {str(Path(__file__).resolve().parents[1])!r}); "
        "import warnings; warnings.simplefilter('ignore'); "
        "from benchmarks.bench_perception import _child, _stages; "
        f"modes, frames, quality = {modes!r}, {frames}, {quality!r}; "
        "print(json.dumps([_stages(frames, quality) if mode == 'stages' "
        "else _child(mode, frames, quality) for mode in modes]))"
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
        raise RuntimeError(f"bench_perception {modes} {quality}: {done.stderr.strip()[-2000:]}")
    result: list[dict[str, Any]] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


MODES = ("rgb", "renders", "native", "labelled", "stages")


def _rounds(frames: int, rounds: int, quality: str, fresh: bool) -> dict[str, list[dict[str, Any]]]:
    """Each mode's results over `rounds` rounds that take the modes in turn: each in a
    fresh process, or (`fresh` False, a quick check) all of a round in one."""
    results: dict[str, list[dict[str, Any]]] = {mode: [] for mode in MODES}
    for _ in range(rounds):
        if fresh:
            for mode in MODES:
                results[mode] += _measure((mode,), frames, quality)
        else:
            for mode, result in zip(MODES, _measure(MODES, frames, quality), strict=True):
                results[mode].append(result)
    return results


def _interval(values: list[float], form: str) -> str:
    """A 95% interval of the median of `values` ("" under 6 rounds)."""
    interval = median_interval(values)
    return f"{form.format(interval[0])} to {form.format(interval[1])}" if interval else ""


def stage_rows(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """CPU ms per labelled frame by stage (median, least and 95% interval of the median
    of the rounds' `results`), then the renders' sum and all stages' sum with the frames/s
    each allows one core, and labelling and writing over the bare renders (pose and
    renders; the image randomisers counted as labelling) and over the frames (pose,
    renders, image randomisers)."""
    rounds = len(results)
    load = round(os.getloadavg()[0], 2)
    renders = set(results[0]["renders"])
    pose = "pose (randomisers, mj_forward)"
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
            "median_95ci": _interval(values, "{:.1f}"),
            "frames_per_s_bound": "",
            "load_1min": load,
        })  # fmt: skip
    for key, what in (("renders", "sum of the renders"), ("all", "sum of all stages")):
        least = min(sums[key])
        rows.append({
            "stage": what,
            "cpu_ms_median": round(statistics.median(sums[key]), 1),
            "cpu_ms_least": round(least, 1),
            "median_95ci": _interval(sums[key], "{:.1f}"),
            "frames_per_s_bound": round(1000 / least, 2),
            "load_1min": load,
        })  # fmt: skip
    image = results[0]["image"]
    bare = [sums["renders"][k] + results[k]["ms"][pose] for k in range(rounds)]
    made = [bare[k] + results[k]["ms"][image] for k in range(rounds)]
    for what, bop, base, under in (
        ("", True, bare, "the bare renders (pose + renders)"),
        (", native only", False, bare, "the bare renders (pose + renders)"),
        ("", True, made, "the frames (pose + renders + image randomisers)"),
        (", native only", False, made, "the frames (pose + renders + image randomisers)"),
    ):
        over = [
            (sums["all"][k] - (0.0 if bop else results[k]["ms"][WRITE_BOP]) - base[k]) / base[k]
            for k in range(rounds)
        ]
        rows.append({
            "stage": f"labelling + writing{what} over {under}",
            "cpu_ms_median": f"{statistics.median(over):+.0%}",
            "cpu_ms_least": f"{min(over):+.0%}",
            "median_95ci": _interval(over, "{:+.0%}"),
            "frames_per_s_bound": "",
            "load_1min": load,
        })  # fmt: skip
    return rows


def run(
    frames: int = FRAMES,
    rounds: int = ROUNDS,
    qualities: tuple[str, ...] = QUALITIES,
    fresh: bool = True,
) -> dict[str, list[dict[str, Any]]]:
    """Per quality: frames/s of bare RGB renders, RGB + depth + segmentation renders, and
    labelled and written frames (best, median and 95% interval of the median of `rounds`
    rounds that take each mode in turn, each in a fresh process unless `fresh` is False);
    and `stage_rows`."""
    load = os.getloadavg()[0]
    rows, stages = [], {}
    for quality in qualities:
        results = _rounds(frames, rounds, quality, fresh)
        stages[quality] = stage_rows(results["stages"])
        modes = ("rgb", "renders", "native", "labelled")
        best = {mode: max(r["fps"] for r in results[mode]) for mode in modes}
        median = {mode: statistics.median(r["fps"] for r in results[mode]) for mode in modes}
        for mode, what in (
            ("rgb", "RGB render only (posed, randomised)"),
            ("renders", "RGB + depth + segmentation renders (bare)"),
            ("native", "labelled + written, native layout only"),
            ("labelled", "labelled + written (native, COCO, BOP)"),
        ):
            rows.append({
                "quality": quality,
                "mode": what,
                "fps_best": round(best[mode], 2),
                "fps_median": round(median[mode], 2),
                "fps_median_95ci": _interval([r["fps"] for r in results[mode]], "{:.2f}"),
                "cost_over_bare": (
                    f"{best['renders'] / best[mode] - 1:+.0%}"
                    if mode in ("native", "labelled")
                    else ""
                ),
                "first_frame_s": round(min(r["first_frame_s"] for r in results[mode]), 2),
                "peak_rss_mb": round(max(r["peak_rss_mb"] for r in results[mode])),
                "load_1min": round(load, 2),
            })  # fmt: skip
    tables = {"Perception: frames/s on one core": rows}
    for quality, table in stages.items():
        tables[f"Perception: CPU per labelled frame, by stage ({quality})"] = table
    return tables


if __name__ == "__main__":
    from benchmarks.table import format_table
    from benchmarks.usage import exit_on_help

    exit_on_help(
        __doc__,
        "  --quick     2 frames, 1 round, fast only, one process (a check that it runs)\n"
        "  --markdown  Markdown tables",
    )
    quick = "--quick" in sys.argv
    tables = run(2, 1, ("fast",), fresh=False) if quick else run()
    for title, table in tables.items():
        print(f"### {title}\n")
        print(format_table(table, markdown="--markdown" in sys.argv) + "\n")
