"""`simbridge datagen SCENE`: a labelled, randomised image dataset of a scene (native layout,
COCO, BOP) with progress, a one-line summary and `--resume`; `simbridge demo datagen`
runs it on the shipped pick-and-place table."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

__all__ = [
    "DATAGEN_SCENES",
    "add_parser",
    "parse_formats",
    "run_datagen",
    "run_demo",
    "scene_path",
]

DATAGEN_SCENES = ("pick-and-place",)
"""Shipped scenes with a `perception:` section, by the name `simbridge datagen` takes."""
ALL_FORMATS = ("coco", "bop", "native")


def parse_formats(text: str) -> tuple[str, ...]:
    """`coco,bop,native` -> the formats beside the native layout (always written)."""
    from simbridge.errors import PerceptionError, did_you_mean

    names = [n.strip() for n in text.split(",") if n.strip()]
    for name in names:
        if name not in ALL_FORMATS:
            raise PerceptionError(
                f"--format: unknown format {name!r}{did_you_mean(name, ALL_FORMATS)} "
                f"(valid: {', '.join(ALL_FORMATS)}, comma-separated)"
            )
    return tuple(n for n in ("coco", "bop") if n in names)


def scene_path(text: str) -> Path:
    """A scene file, else a shipped datagen scene's name."""
    from simbridge.apps.datagen import SCENE
    from simbridge.errors import PerceptionError, did_you_mean

    given = Path(text)
    if given.exists() or given.suffix in (".yaml", ".yml") or "/" in text:
        if not given.is_file():
            raise PerceptionError(f"no scene file '{text}'")
        return given
    if text not in DATAGEN_SCENES:
        raise PerceptionError(
            f"no scene file or shipped datagen scene '{text}'"
            f"{did_you_mean(text, DATAGEN_SCENES)} (shipped: {', '.join(DATAGEN_SCENES)}; "
            "or a path to a scene YAML file with a 'perception:' section)"
        )
    return SCENE


def run_datagen(
    scene: Path,
    frames: int,
    out: Path,
    *,
    formats: tuple[str, ...],
    seed: int,
    resume: bool,
    workers: int,
    quality: str | None = None,
) -> int:
    """Make the dataset with a status line on stderr and print a summary line."""
    from simbridge.perception import DatagenJob, first_missing_frame, generate
    from simbridge.progress import Ticker, elapsed

    job = DatagenJob(str(scene), seed=seed, formats=formats, quality=quality)
    start = first_missing_frame(out, frames) if resume else 0
    todo = frames - start
    done = [0]
    began = time.perf_counter()

    def status() -> str:
        if todo and done[0] == todo:
            return f"datagen: {frames} frames rendered; writing the dataset files"
        spent = time.perf_counter() - began
        rate = done[0] / spent if spent > 0 else 0.0
        left = f", {elapsed((todo - done[0]) / rate)} left" if rate > 0 else ""
        return f"datagen: frame {start + done[0]}/{frames} ({rate:.1f} frames/s{left})"

    def report(count: int) -> None:
        done[0] = count

    with Ticker(status, every=1.0, plain_every=1.0):
        summary = generate(job, frames, out, resume=resume, report=report, workers=workers)
    wall = time.perf_counter() - began
    rate = f", {todo / wall:.1f} frames/s" if todo else ""
    kinds = ", ".join(("native", *formats))
    print(
        f"datagen: {summary.frames} frames ({todo} rendered now{rate}, {workers} "
        f"worker{'s' if workers > 1 else ''}), {summary.images} images, {summary.annotations} "
        f"COCO annotations, {summary.instances} labelled instances of {scene.name} seed {seed} "
        f"-> {out}/ ({kinds}; contact_sheet.png) in {elapsed(wall)}"
    )
    return 0


def _run(args: argparse.Namespace) -> int:
    return _make(scene_path(args.scene), args, ray=args.ray)


def run_demo(args: argparse.Namespace) -> int:
    """`simbridge demo datagen`: the shipped pick-and-place table."""
    return _make(scene_path("pick-and-place"), args)


def _make(scene: Path, args: argparse.Namespace, *, ray: str | None = None) -> int:
    """The dataset `args` asks for of `scene`: on the Ray cluster at `ray`, else here."""
    frames, out, formats = args.frames, Path(args.out), parse_formats(args.format)
    seed, resume, quality = args.seed, args.resume, args.quality
    if ray:
        from .datagen_ray import run_datagen_on_ray

        return run_datagen_on_ray(
            scene,
            frames,
            out,
            formats=formats,
            seed=seed,
            resume=resume,
            address=ray,
            chunk=args.chunk,
            quality=quality,
        )
    return run_datagen(
        scene,
        frames,
        out,
        formats=formats,
        seed=seed,
        resume=resume,
        workers=args.workers,
        quality=quality,
    )


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from simbridge.apps import options

    p = sub.add_parser(
        "datagen",
        help="a labelled, randomised image dataset of a scene (COCO, BOP, native)",
        description="Render a scene's `perception:` cameras N times, randomised and labelled "
        "(RGB, depth, segmentation, 2D/3D boxes, 6D poses, keypoints), into OUT: the native "
        "layout, COCO and BOP, and a contact sheet. See docs/perception.md.",
    )
    p.add_argument(
        "scene",
        metavar="SCENE",
        help="a scene YAML file with a 'perception:' section, or a shipped one: "
        + ", ".join(DATAGEN_SCENES),
    )
    options.add_datagen_arguments(p, frames=None)
    p.add_argument(
        "--ray",
        metavar="ADDRESS",
        help="render on the Ray cluster at HOST:PORT ('auto': the one `ray start` runs on "
        "this machine), one task of --chunk frames per CPU (--workers is then unused); the "
        "same bytes as here; needs `pip install 'simbridge[ray]'` (docs/ray.md)",
    )
    p.add_argument(
        "--chunk",
        type=int,
        help="with --ray: frames per task (default 25)",
    )
    p.set_defaults(func=_run)
