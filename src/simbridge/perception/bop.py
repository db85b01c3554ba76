"""BOP layout (the format of the BOP 6D pose benchmark), one BOP scene per camera:

    bop/camera.json                          the first camera's intrinsics, depth_scale
    bop/train_pbr/000000/rgb/000042.png      frame 42 of camera 0
    bop/train_pbr/000000/depth/000042.png    16-bit depth: mm = value * depth_scale
    bop/train_pbr/000000/mask/000042_000003.png        amodal silhouette of GT 3
    bop/train_pbr/000000/mask_visib/000042_000003.png  its visible part
    bop/train_pbr/000000/scene_camera.json   per image: cam_K, depth_scale, cam_R_w2c, cam_t_w2c
    bop/train_pbr/000000/scene_gt.json       per image: cam_R_m2c, cam_t_m2c (mm), obj_id
    bop/train_pbr/000000/scene_gt_info.json  per image: bbox_obj, bbox_visib, px counts, visib_fract

obj_id is the class id (a BOP object is a model, shared by its instances); the model frame
is the instance's root body frame. Images list every labelled instance whose silhouette
reaches into the image, hidden ones included.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from simbridge.perception.frames import Frame
from simbridge.perception.native import json_bytes, write_atomic
from simbridge.perception.png import png_bytes

__all__ = ["BOP_SPLIT", "bop_documents", "write_bop_frame"]

BOP_SPLIT = "bop/train_pbr"
MAX_DEPTH_VALUE = 65535


def _scene(camera_index: int) -> str:
    return f"{BOP_SPLIT}/{camera_index:06d}"


def depth_png(depth: NDArray[np.float32], depth_scale: float) -> NDArray[np.uint16]:
    """Depth (m) as BOP's 16-bit values (mm / depth_scale); 0 where none or out of range."""
    values = depth.astype(np.float64)
    values *= 1000.0 / depth_scale  # in place: 0.5 ms a 640x480 frame, a new array 4 ms
    np.rint(values, out=values)
    values[(values > MAX_DEPTH_VALUE) | (values < 0)] = 0
    return values.astype(np.uint16)


def write_bop_frame(
    root: Path, frame: Frame, rgb_pngs: list[bytes | None], depth_scale: float, png_level: int
) -> None:
    """The frame's images and masks under each camera's BOP scene."""
    for c, view in enumerate(frame.views):
        scene = root / _scene(c)
        index = frame.index
        png = rgb_pngs[c]
        if png is not None:
            write_atomic(scene / "rgb" / f"{index:06d}.png", png)
        if view.depth is not None:
            write_atomic(
                scene / "depth" / f"{index:06d}.png",
                png_bytes(depth_png(view.depth, depth_scale), png_level),
            )
        shape = (view.camera.height, view.camera.width)
        for gt, label in enumerate(view.labels.instances):
            full = np.zeros(shape, dtype=bool)
            if label.amodal_mask is not None:
                mask, (u0, v0) = label.amodal_mask
                full[v0 : v0 + mask.shape[0], u0 : u0 + mask.shape[1]] = mask
            name = f"{index:06d}_{gt:06d}.png"
            write_atomic(scene / "mask" / name, png_bytes(full, png_level))
            full[:] = False
            if label.visible_mask is not None and label.tight_box is not None:
                x0, y0, _, _ = label.tight_box
                visible = label.visible_mask
                full[y0 : y0 + visible.shape[0], x0 : x0 + visible.shape[1]] = visible
            write_atomic(scene / "mask_visib" / name, png_bytes(full, png_level))


def _flat(matrix: list[list[float]]) -> list[float]:
    return [v for row in matrix for v in row]


def _mm(values: list[float]) -> list[float]:
    return [round(v * 1000.0, 6) for v in values]


def _bbox_obj(box: list[float]) -> list[int]:
    x0, y0, x1, y1 = box
    return [
        int(np.floor(x0 + 0.5)),
        int(np.floor(y0 + 0.5)),
        round(x1 - x0),
        round(y1 - y0),
    ]


def bop_documents(
    records: Iterable[dict[str, Any]], depth_scale: float, camera: dict[str, Any]
) -> dict[str, bytes]:
    """The BOP JSON files (path -> bytes) from the frames' native records, in frame order;
    `camera` (the first declared camera: fx, fy, cx, cy, width, height) is camera.json's."""
    cameras: dict[int, dict[str, dict[str, Any]]] = {}
    gts: dict[int, dict[str, list[dict[str, Any]]]] = {}
    infos: dict[int, dict[str, list[dict[str, Any]]]] = {}
    for record in records:
        key = str(record["frame"])
        for c, view in enumerate(record["views"]):
            world_from_camera = np.array(view["world_from_camera"])
            rotation = world_from_camera[:3, :3].T
            translation = -rotation @ world_from_camera[:3, 3]
            cameras.setdefault(c, {})[key] = {
                "cam_K": _flat(view["K"]),
                "depth_scale": depth_scale,
                "cam_R_w2c": [round(float(v), 9) for v in rotation.reshape(-1)],
                "cam_t_w2c": _mm(translation.tolist()),
            }
            gt_list, info_list = [], []
            for inst in view["instances"]:
                gt_list.append(
                    {
                        "cam_R_m2c": _flat(inst["pose"]["rotation"]),
                        "cam_t_m2c": _mm(inst["pose"]["translation"]),
                        "obj_id": inst["class_id"],
                    }
                )
                tight = inst["box_tight"]
                visib = (
                    [tight[0], tight[1], tight[2] - tight[0], tight[3] - tight[1]]
                    if tight is not None
                    else [-1, -1, -1, -1]
                )
                info_list.append(
                    {
                        "bbox_obj": _bbox_obj(inst["box_amodal"]),
                        "bbox_visib": visib,
                        "px_count_all": inst["amodal_px"],
                        "px_count_valid": inst.get("valid_px", inst["amodal_px"]),
                        "px_count_visib": inst["visible_px"],
                        "visib_fract": inst["visibility"],
                    }
                )
            gts.setdefault(c, {})[key] = gt_list
            infos.setdefault(c, {})[key] = info_list
    files: dict[str, bytes] = {}
    for c in sorted(cameras):
        files[f"{_scene(c)}/scene_camera.json"] = json_bytes(cameras[c])
        files[f"{_scene(c)}/scene_gt.json"] = json_bytes(gts[c])
        files[f"{_scene(c)}/scene_gt_info.json"] = json_bytes(infos[c])
    files["bop/camera.json"] = json_bytes(
        {
            "cx": camera["cx"],
            "cy": camera["cy"],
            "fx": camera["fx"],
            "fy": camera["fy"],
            "width": camera["width"],
            "height": camera["height"],
            "depth_scale": depth_scale,
        }
    )
    return files
