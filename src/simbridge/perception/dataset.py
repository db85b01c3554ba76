"""Datasets: frames rendered into shard folders by a pure function, merged into one dataset.

The API (stable; `simbridge datagen` and the Ray runner of simbridge.cluster both use it):

- `DatagenJob(scene, seed, formats, quality)`: what to make. Picklable; `scene` is a path
  every worker can read; `quality` a render preset over the scene's (None: the scene's).
- `render_frames(job, frames, folder, report=None)`: render the frame indices `frames`
  (any iterable of ints: a range, a list) into `folder`, calling `report(done)` after each
  frame. Frame i's randomness comes from `numpy.random.SeedSequence(seed,
  spawn_key=(i, k))` for randomiser k alone, so a frame's files are the same whichever
  process renders it, in whatever order, alone or among others. Its signature fits
  `simbridge.cluster.shards.RenderChunk` as `functools.partial(render_frames, job)`.
- `merge_shards(job, shards, out, frames)`: copy the shards' files into `out` (a shard may
  be `out` itself) and write the files made from all frames (COCO and BOP annotation
  files, dataset.json, the contact sheet) from frames 0 .. frames - 1. One shard of all
  frames and many shards merged give byte-identical datasets.
- `first_missing_frame(out, frames)`: where `--resume` continues.
- `generate(job, frames, out, resume=False, report=None, workers=1)`: render (in this
  process, or in `workers` fresh processes, each a shard of frames) and merge.

A frame is done when its `native/frames/NNNNNN.json` exists (written last, atomically);
every other file of it is written before, each atomically.
"""

from __future__ import annotations

import json
import multiprocessing
import shutil
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from simbridge.errors import PerceptionError
from simbridge.perception.bop import bop_documents, write_bop_frame
from simbridge.perception.coco import coco_document
from simbridge.perception.contact_sheet import contact_sheet
from simbridge.perception.frames import FrameMaker
from simbridge.perception.native import (
    frame_json_path,
    json_bytes,
    read_frame,
    write_atomic,
    write_native,
)
from simbridge.perception.render import QUALITIES

__all__ = [
    "ENCODING",
    "FORMATS",
    "SCHEMA",
    "DatagenJob",
    "DatasetSummary",
    "first_missing_frame",
    "generate",
    "merge_shards",
    "render_frames",
]

FORMATS = ("coco", "bop")
"""Formats beside the native layout, which is always written."""
SCHEMA = "simbridge-perception/1"
ENCODING = 2
"""Which encoders wrote the files, raised whenever the same pixels and labels come out as
other bytes (2: noisy colour PNGs Huffman-coded, 2026-11-29; tests/perception/
test_golden_bytes.py pins the bytes of each). `--resume` continues only a dataset of this
encoding, so a dataset never mixes two."""
META = "native/dataset.json"


@dataclass(frozen=True)
class DatagenJob:
    """A dataset to make: the scene file, the seed, the formats beside the native one, and
    a render quality preset over the scene's (None: the scene's own)."""

    scene: str
    seed: int = 0
    formats: tuple[str, ...] = FORMATS
    quality: str | None = None

    def __post_init__(self) -> None:
        for name in self.formats:
            if name not in FORMATS:
                raise PerceptionError(f"unknown format {name!r} (valid: {', '.join(FORMATS)})")
        if self.quality is not None and self.quality not in QUALITIES:
            raise PerceptionError(
                f"unknown render quality {self.quality!r} (valid: {', '.join(QUALITIES)})"
            )
        if self.seed < 0:
            raise PerceptionError(f"seed must be >= 0, got {self.seed}")


@dataclass(frozen=True)
class DatasetSummary:
    """What a merge wrote."""

    out: Path
    frames: int
    images: int
    annotations: int
    """COCO annotations (instances with visible pixels)."""
    instances: int
    """Instance entries over all views, hidden ones included (BOP's GT count)."""


_maker: tuple[DatagenJob, FrameMaker] | None = None


def _frame_maker(job: DatagenJob) -> FrameMaker:
    """The job's scene, built once per process (a worker rendering many chunks reuses it)."""
    global _maker
    if _maker is None or _maker[0] != job:
        if _maker is not None:
            _maker[1].close()
        _maker = (job, FrameMaker(job.scene, job.seed, job.quality))
    return _maker[1]


def _meta(job: DatagenJob, maker: FrameMaker) -> dict[str, Any]:
    """What the dataset is: a function of the job alone (same in every shard)."""
    config, table = maker.config, maker.table
    keypoints: dict[str, dict[str, Any]] = {}
    model = maker.world.model
    for inst in table.instances:
        if (
            inst.kind == "robot"
            and "keypoints" in config.labelers
            and inst.category not in keypoints
        ):
            position = {body: k for k, body in enumerate(inst.bodies)}
            skeleton = [
                [position[int(model.body_parentid[b])] + 1, k + 1]
                for k, b in enumerate(inst.bodies)
                if int(model.body_parentid[b]) in position
            ]
            names = [model.body(b).name for b in inst.bodies]
            keypoints[inst.category] = {"names": names, "skeleton": skeleton}
    return {
        "schema": SCHEMA,
        "encoding": ENCODING,
        "scene": Path(job.scene).name,
        "seed": job.seed,
        "formats": list(job.formats),
        "render": {
            "shadows": config.render.shadows,
            "multisamples": config.render.multisamples,
            "shadow_size": config.render.shadow_size,
        },
        "labelers": sorted(config.labelers),
        "depth_scale": config.output.depth_scale,
        "min_visible_px": config.output.min_visible_px,
        "contact_sheet": config.output.contact_sheet,
        "conventions": {
            "camera_frame": "REP 103 optical frame: x right, y down, z forward",
            "pixels": "pixel (column i, row j) has its centre at (u, v) = (i, j)",
            "depth": "metres along the optical axis (z), 0 where nothing was hit",
        },
        "cameras": [
            {
                "name": c.name,
                "width": c.width,
                "height": c.height,
                "fx": c.fx,
                "fy": c.fy,
                "cx": c.cx,
                "cy": c.cy,
            }
            for c in config.cameras
        ],
        "classes": [{"id": i, "name": n} for i, n in enumerate(table.categories, start=1)],
        "instances": [
            {
                "id": i.id,
                "name": i.name,
                "class": i.category,
                "class_id": i.category_id,
                "kind": i.kind,
            }
            for i in table.instances
        ],
        "keypoints": keypoints,
    }


def render_frames(
    job: DatagenJob,
    frames: Iterable[int],
    folder: Path,
    report: Callable[[int], None] | None = None,
) -> int:
    """Render `frames` into `folder` (see the module docstring); returns the count."""
    maker = _frame_maker(job)
    folder = Path(folder)
    write_atomic(folder / META, json_bytes(_meta(job, maker)))
    output = maker.config.output
    done = 0
    for index in frames:
        if index < 0:
            raise PerceptionError(f"frame indices are >= 0, got {index}")
        frame = maker.make(index)
        record, pngs = write_native(folder, frame, output.png_compression)
        if "bop" in job.formats:
            write_bop_frame(folder, frame, pngs, output.depth_scale, output.png_compression)
        write_atomic(frame_json_path(folder, index), json_bytes(record))
        done += 1
        if report is not None:
            report(done)
    return done


def first_missing_frame(out: Path, frames: int) -> int:
    """The first frame index below `frames` whose JSON is not in `out` (`frames` if none)."""
    for index in range(frames):
        if not frame_json_path(out, index).exists():
            return index
    return frames


def _copy_shard(shard: Path, out: Path) -> None:
    if shard.resolve() == out.resolve():
        return
    if not shard.is_dir():
        raise PerceptionError(f"shard '{shard}' is not a folder")
    for path in sorted(shard.rglob("*")):
        if path.is_file() and not path.name.startswith("."):
            target = out / path.relative_to(shard)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, target)


def merge_shards(job: DatagenJob, shards: Sequence[Path], out: Path, frames: int) -> DatasetSummary:
    """Gather `shards` into `out` and write the dataset-wide files (module docstring)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    for shard in shards:
        _copy_shard(Path(shard), out)
    missing = first_missing_frame(out, frames)
    if missing < frames:
        raise PerceptionError(f"cannot merge: frame {missing} of {frames} is in no shard")
    if not (out / META).exists():
        raise PerceptionError(f"cannot merge: no {META} in the shards (nothing rendered?)")
    meta = json.loads((out / META).read_text())
    if meta["seed"] != job.seed or meta["formats"] != list(job.formats):
        raise PerceptionError(
            f"cannot merge: the shards were made with seed {meta['seed']} and formats "
            f"{meta['formats']}, not seed {job.seed} and formats {list(job.formats)}"
        )
    records = [read_frame(out, index) for index in range(frames)]
    classes = [c["name"] for c in meta["classes"]]
    cameras = len(meta["cameras"])
    annotations = 0
    if "coco" in job.formats:
        document = coco_document(
            records, classes, meta["keypoints"], cameras, meta["min_visible_px"]
        )
        annotations = len(document["annotations"])
        write_atomic(out / "coco" / "annotations.json", json_bytes(document))
    if "bop" in job.formats:
        for name, data in bop_documents(records, meta["depth_scale"], meta["cameras"][0]).items():
            write_atomic(out / name, data)
    sheet = int(meta["contact_sheet"])
    if sheet:
        write_atomic(out / "contact_sheet.png", contact_sheet(out, records, sheet))
    write_atomic(out / "dataset.json", json_bytes({**meta, "frames": frames}))
    return DatasetSummary(
        out,
        frames,
        frames * cameras,
        annotations,
        sum(len(v["instances"]) for r in records for v in r["views"]),
    )


def _render_in_workers(
    job: DatagenJob,
    frames: range,
    out: Path,
    workers: int,
    report: Callable[[int], None] | None,
) -> None:
    """`frames` rendered into `out` by `workers` fresh (spawned) processes, in chunks small
    enough that `report` hears of progress often."""
    chunk = max(1, min(8, len(frames) // (workers * 4)))
    chunks = [frames[i : i + chunk] for i in range(0, len(frames), chunk)]
    context = multiprocessing.get_context("spawn")  # never fork a process holding GL
    done = 0
    with ProcessPoolExecutor(workers, mp_context=context) as pool:
        futures = [pool.submit(render_frames, job, part, out) for part in chunks]
        try:
            for future in as_completed(futures):
                done += future.result()
                if report is not None:
                    report(done)
        except BaseException:
            for future in futures:
                future.cancel()
            raise


def generate(
    job: DatagenJob,
    frames: int,
    out: Path,
    *,
    resume: bool = False,
    report: Callable[[int], None] | None = None,
    workers: int = 1,
) -> DatasetSummary:
    """Render frames 0 .. frames - 1 into `out` and merge; `resume` continues at the first
    missing frame of a dataset of the same job (`report(done)` counts from there);
    `workers` > 1 renders in that many processes (the same bytes as one)."""
    if frames < 1:
        raise PerceptionError(f"--frames must be >= 1, got {frames}")
    if workers < 1:
        raise PerceptionError(f"--workers must be >= 1, got {workers}")
    out = Path(out)
    start = 0
    if (out / META).exists():
        if not resume:
            raise PerceptionError(
                f"'{out}' already holds a dataset; pass --resume to continue it or choose "
                "another folder"
            )
        data = (out / META).read_bytes()
        try:
            written = json.loads(data)
        except ValueError as exc:  # not JSON, or not UTF-8
            raise PerceptionError(
                f"'{out / META}': {exc}: not the JSON datagen writes; it cannot be resumed"
            ) from exc
        if not isinstance(written, dict):
            raise PerceptionError(
                f"'{out / META}' holds a JSON {type(written).__name__}, not the object "
                "datagen writes; it cannot be resumed"
            )
        if written.get("encoding") != ENCODING:
            raise PerceptionError(
                f"'{out}' was written by another version of simbridge (file encoding "
                f"{written.get('encoding', 1)}, this version writes {ENCODING}: the same "
                "frames as other bytes); it cannot be resumed: render it again into a new "
                "folder"
            )
        maker = _frame_maker(job)
        if data != json_bytes(_meta(job, maker)):
            raise PerceptionError(
                f"'{out}' holds a dataset of another scene, seed, format, labeler set or "
                f"render settings (its {META} differs from this job's); it cannot be resumed "
                "with these options"
            )
        start = first_missing_frame(out, frames)
    todo = range(start, frames)
    if workers > 1 and len(todo) > 1:
        _render_in_workers(job, todo, out, min(workers, len(todo)), report)
    else:
        render_frames(job, todo, out, report)
    return merge_shards(job, [out], out, frames)
