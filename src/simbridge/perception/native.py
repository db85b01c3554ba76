"""The native layout: per frame and camera an RGB PNG and an NPZ of label images, and per
frame one JSON of everything labelled (schema in docs/perception.md). Every file is a pure
function of its content: PNGs and NPZs carry no time stamps, JSON keys keep their order."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from numpy.typing import NDArray

from simbridge.perception.annotate import InstanceLabel, ViewLabels
from simbridge.perception.frames import Frame, View
from simbridge.perception.npz import write_npz_to
from simbridge.perception.png import png_bytes
from simbridge.perception.rle import rle

__all__ = [
    "FRAMES_DIR",
    "atomic_file",
    "frame_json_path",
    "frame_record",
    "json_bytes",
    "read_frame",
    "write_atomic",
    "write_native",
    "write_npz",
]

FRAMES_DIR = "native/frames"


def frame_json_path(root: Path, index: int) -> Path:
    """Where frame `index`'s JSON is (written last: its presence means the frame is done)."""
    return root / FRAMES_DIR / f"{index:06d}.json"


def rgb_path(camera: str, index: int) -> str:
    return f"native/{camera}/{index:06d}.png"


def labels_path(camera: str, index: int) -> str:
    return f"native/{camera}/{index:06d}.npz"


@contextmanager
def atomic_file(path: Path) -> Iterator[BinaryIO]:
    """A file to write that appears at `path` whole when the block ends, or not at all
    (a sibling file renamed into place)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    # One partial file per process: workers of one dataset write the same dataset.json.
    partial = path.with_name(f".{path.name}.{os.getpid()}.partial")
    try:
        with partial.open("wb") as file:
            yield file
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
    os.replace(partial, path)


def write_atomic(path: Path, data: bytes) -> None:
    """Write `data` to `path` whole or not at all."""
    with atomic_file(path) as file:
        file.write(data)


def write_npz(path: Path, arrays: dict[str, NDArray[Any]]) -> None:
    """An uncompressed .npz (np.load reads it) with fixed member dates, so equal arrays give
    equal bytes (npz.py), whole or not at all."""
    with atomic_file(path) as file:
        write_npz_to(file, arrays)


def _r(value: float, digits: int = 6) -> float:
    return round(float(value), digits)


def _matrix(values: NDArray[np.float64], digits: int = 9) -> list[list[float]]:
    return [[_r(v, digits) for v in row] for row in values]


def instance_record(
    label: InstanceLabel, shape: tuple[int, int], valid_px: int | None
) -> dict[str, Any]:
    """One instance's entry in a view of the frame JSON."""
    inst = label.instance
    record: dict[str, Any] = {
        "id": inst.id,
        "name": inst.name,
        "class": inst.category,
        "class_id": inst.category_id,
        "visible_px": label.visible_px,
        "amodal_px": label.amodal_px,
        "visibility": _r(label.visibility),
        "truncation": _r(label.truncation),
        "box_tight": list(label.tight_box) if label.tight_box is not None else None,
        "box_amodal": [_r(v, 4) for v in label.amodal_box],
        "pose": {
            "rotation": _matrix(label.rotation),
            "translation": [_r(v, 9) for v in label.translation],
        },
    }
    if valid_px is not None:
        record["valid_px"] = valid_px
    if label.box3d is not None:
        record["box_3d"] = {
            "center": [_r(v, 9) for v in label.box3d.center],
            "size": [_r(v, 9) for v in label.box3d.size],
            "rotation": _matrix(label.box3d.rotation),
        }
    if label.visible_mask is not None and label.tight_box is not None:
        record["rle"] = rle(label.visible_mask, (label.tight_box[0], label.tight_box[1]), shape)
    if label.keypoints is not None:
        record["keypoints"] = [[_r(u, 4), _r(v, 4), int(f)] for u, v, f in label.keypoints]
    return record


def _valid_px(label: InstanceLabel, depth: NDArray[np.float32] | None) -> int | None:
    """Pixels of the in-image silhouette with a depth (BOP's px_count_valid)."""
    if depth is None or label.amodal_mask is None:
        return None
    mask, (u0, v0) = label.amodal_mask
    region = depth[v0 : v0 + mask.shape[0], u0 : u0 + mask.shape[1]]
    return int((mask & (region > 0)).sum())


def view_record(view: View, index: int, labels: ViewLabels) -> dict[str, Any]:
    camera = view.camera
    shape = (camera.height, camera.width)
    return {
        "camera": camera.name,
        "width": camera.width,
        "height": camera.height,
        "K": _matrix(camera.matrix),
        "world_from_camera": _matrix(camera.pose_matrix()),
        "rgb": rgb_path(camera.name, index) if view.rgb is not None else None,
        "labels": labels_path(camera.name, index),
        "instances": [
            instance_record(i, shape, _valid_px(i, view.depth)) for i in labels.instances
        ],
    }


def frame_record(frame: Frame) -> dict[str, Any]:
    """The frame's JSON document."""
    return {
        "frame": frame.index,
        "views": [view_record(v, frame.index, v.labels) for v in frame.views],
    }


def write_native(
    root: Path, frame: Frame, png_level: int
) -> tuple[dict[str, Any], list[bytes | None]]:
    """Write the frame's images and label arrays; returns its JSON record (not yet written:
    the caller writes it last, after every other format's files) and each view's RGB PNG."""
    pngs: list[bytes | None] = []
    for view in frame.views:
        name = view.camera.name
        png = png_bytes(view.rgb, png_level) if view.rgb is not None else None
        pngs.append(png)
        if png is not None:
            write_atomic(root / rgb_path(name, frame.index), png)
        arrays: dict[str, NDArray[Any]] = {}
        if view.depth is not None:
            arrays["depth"] = view.depth
        if view.labels.instance_image is not None:
            arrays["instance"] = view.labels.instance_image
        if view.labels.category_image is not None:
            arrays["semantic"] = view.labels.category_image
        write_npz(root / labels_path(name, frame.index), arrays)
    return frame_record(frame), pngs


def json_bytes(document: Any) -> bytes:
    """Compact, key-order-preserving JSON with a final newline."""
    return (json.dumps(document, separators=(",", ":")) + "\n").encode()


def read_frame(root: Path, index: int) -> dict[str, Any]:
    """Frame `index`'s JSON document."""
    result: dict[str, Any] = json.loads(frame_json_path(root, index).read_text())
    return result
