"""COCO instance segmentation (with keypoints for robots): one image per frame and camera,
one annotation per instance with visible pixels, masks as compressed RLE.

Image ids are frame * cameras + camera index + 1; `file_name` is the RGB image's path from
the dataset folder. Boxes follow COCO: [x, y, width, height] where pixel (i, j) covers
[i, i + 1) x [j, j + 1), so the tight box of the visible pixels is exactly pycocotools'
`toBbox` of the mask; `bbox_amodal` and keypoints are in the same convention (projected
coordinates + 0.5). Extra fields: instance_id, visibility, truncation, bbox_amodal.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

__all__ = ["coco_document"]


def coco_document(
    records: Iterable[dict[str, Any]],
    categories: Sequence[str],
    keypoints: dict[str, dict[str, Any]],
    cameras: int,
    min_visible_px: int,
) -> dict[str, Any]:
    """The COCO annotation document of the frames' native records (in frame order);
    `keypoints` maps a class to {"names", "skeleton"} (1-based pairs)."""
    images: list[dict[str, Any]] = []
    annotations: list[dict[str, Any]] = []
    for record in records:
        for c, view in enumerate(record["views"]):
            image_id = record["frame"] * cameras + c + 1
            images.append(
                {
                    "id": image_id,
                    "file_name": view["rgb"],
                    "width": view["width"],
                    "height": view["height"],
                    "frame": record["frame"],
                    "camera": view["camera"],
                }
            )
            for inst in view["instances"]:
                if inst["visible_px"] < min_visible_px or "rle" not in inst:
                    continue
                x0, y0, x1, y1 = inst["box_tight"]
                u0, v0, u1, v1 = inst["box_amodal"]
                entry: dict[str, Any] = {
                    "id": len(annotations) + 1,
                    "image_id": image_id,
                    "category_id": inst["class_id"],
                    "segmentation": inst["rle"],
                    "area": inst["visible_px"],
                    "bbox": [x0, y0, x1 - x0 + 1, y1 - y0 + 1],
                    "iscrowd": 0,
                    "instance_id": inst["id"],
                    "visibility": inst["visibility"],
                    "truncation": inst["truncation"],
                    "bbox_amodal": [
                        round(u0 + 0.5, 4),
                        round(v0 + 0.5, 4),
                        round(u1 - u0, 4),
                        round(v1 - v0, 4),
                    ],
                }
                if "keypoints" in inst:
                    flat: list[float] = []
                    for u, v, flag in inst["keypoints"]:
                        flat += [round(u + 0.5, 4), round(v + 0.5, 4), flag] if flag else [0, 0, 0]
                    entry["keypoints"] = flat
                    entry["num_keypoints"] = sum(1 for _, _, f in inst["keypoints"] if f)
                annotations.append(entry)
    cats = []
    for index, name in enumerate(categories, start=1):
        category: dict[str, Any] = {"id": index, "name": name, "supercategory": "simbridge"}
        if name in keypoints:
            category["keypoints"] = keypoints[name]["names"]
            category["skeleton"] = keypoints[name]["skeleton"]
        cats.append(category)
    return {
        "info": {"description": "simbridge perception dataset", "version": "1"},
        "images": images,
        "annotations": annotations,
        "categories": cats,
    }
