"""The files as their own tools read them: COCO through pycocotools (masks, boxes and
COCOeval of the ground truth against itself), BOP as its toolkit reads a scene (the three
JSON files keyed by image id, 16-bit depth scaled by depth_scale, masks), and the native
layout they are made from."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image
from pycocotools import mask as mask_utils  # type: ignore[import-untyped]
from pycocotools.coco import COCO  # type: ignore[import-untyped]
from pycocotools.cocoeval import COCOeval  # type: ignore[import-untyped]

from simbridge.perception import DatagenJob, DatasetSummary, generate
from tests.perception.scenes import random_scene

FRAMES = 3
pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning:pycocotools")


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, DatasetSummary]:
    folder = tmp_path_factory.mktemp("formats")
    job = DatagenJob(str(random_scene(folder)), seed=3, formats=("coco", "bop"))
    return folder / "out", generate(job, FRAMES, folder / "out")


def native(root: Path, frame: int) -> dict[str, Any]:
    record: dict[str, Any] = json.loads((root / f"native/frames/{frame:06d}.json").read_text())
    return record


def quiet_coco(path: Path) -> COCO:
    with contextlib.redirect_stdout(io.StringIO()):
        return COCO(str(path))


def test_coco_loads_and_masks_and_boxes_are_the_instance_images(
    dataset: tuple[Path, DatasetSummary],
) -> None:
    root, summary = dataset
    coco = quiet_coco(root / "coco" / "annotations.json")
    assert len(coco.getImgIds()) == summary.images == FRAMES
    assert len(coco.getAnnIds()) == summary.annotations > FRAMES
    assert [c["name"] for c in coco.loadCats(coco.getCatIds())] == ["cube", "can", "distractor"]
    for image in coco.loadImgs(coco.getImgIds()):
        assert (root / image["file_name"]).is_file()
        labels = np.load(root / f"native/main/{image['frame']:06d}.npz")
        for ann in coco.loadAnns(coco.getAnnIds(imgIds=image["id"])):
            mask = mask_utils.decode(ann["segmentation"]).astype(bool)
            assert (mask == (labels["instance"] == ann["instance_id"])).all()
            assert ann["area"] == int(mask.sum()) == int(mask_utils.area(ann["segmentation"]))
            assert ann["bbox"] == mask_utils.toBbox(ann["segmentation"]).tolist()
            assert ann["category_id"] == int(labels["semantic"][mask][0])


def test_cocoeval_of_the_ground_truth_against_itself_is_perfect(
    dataset: tuple[Path, DatasetSummary],
) -> None:
    root, _ = dataset
    coco = quiet_coco(root / "coco" / "annotations.json")
    results = [{**a, "score": 1.0} for a in coco.loadAnns(coco.getAnnIds())]
    with contextlib.redirect_stdout(io.StringIO()):
        detections = coco.loadRes(results)
        for kind in ("segm", "bbox"):
            evaluation = COCOeval(coco, detections, kind)
            evaluation.evaluate()
            evaluation.accumulate()
            evaluation.summarize()
            assert evaluation.stats[0] == pytest.approx(1.0), kind  # AP @ IoU .50:.95


def bop_json(root: Path, name: str) -> dict[int, Any]:
    """A scene file as the BOP toolkit's inout.load_json(keys_to_int=True) reads it."""
    data = json.loads((root / "bop/train_pbr/000000" / name).read_text())
    return {int(k): v for k, v in data.items()}


def test_bop_scene_files_are_what_bop_tooling_reads(dataset: tuple[Path, DatasetSummary]) -> None:
    root, _ = dataset
    cameras, gts, infos = (
        bop_json(root, f"scene_{name}.json") for name in ("camera", "gt", "gt_info")
    )
    assert sorted(cameras) == sorted(gts) == sorted(infos) == list(range(FRAMES))
    camera = json.loads((root / "bop/camera.json").read_text())
    assert {"cx", "cy", "fx", "fy", "width", "height", "depth_scale"} <= set(camera)
    for frame in range(FRAMES):
        view = native(root, frame)["views"][0]
        entry = cameras[frame]
        assert np.allclose(np.reshape(entry["cam_K"], (3, 3)), view["K"])
        # cam_R_w2c, cam_t_w2c (mm) invert the native world-from-camera pose.
        world_from_camera = np.array(view["world_from_camera"])
        w2c = np.eye(4)
        w2c[:3, :3] = np.reshape(entry["cam_R_w2c"], (3, 3))
        w2c[:3, 3] = np.array(entry["cam_t_w2c"]) / 1000.0
        assert np.allclose(w2c @ world_from_camera, np.eye(4), atol=1e-6)
        # Depth: uint16 PNG, mm = value * depth_scale; 0 where nothing was hit or beyond
        # what 16 bits hold (6.5535 m at depth_scale 0.1).
        png = np.asarray(Image.open(root / f"bop/train_pbr/000000/depth/{frame:06d}.png"))
        assert png.dtype == np.uint16
        millimetres = np.load(root / f"native/main/{frame:06d}.npz")["depth"] * 1000.0
        scale = entry["depth_scale"]
        held = (millimetres > 0) & (millimetres / scale < 65535)
        assert held.mean() > 0.5
        assert np.abs(png[held] * scale - millimetres[held]).max() <= scale / 2 + 1e-3
        assert (png[~held] == 0).all()
        assert Image.open(root / f"bop/train_pbr/000000/rgb/{frame:06d}.png").mode == "RGB"
        # One GT and one info per instance, in the same order; poses in mm.
        assert len(gts[frame]) == len(infos[frame]) == len(view["instances"])
        for gt_id, (gt, info, inst) in enumerate(
            zip(gts[frame], infos[frame], view["instances"], strict=True)
        ):
            assert gt["obj_id"] == inst["class_id"]
            assert np.allclose(np.reshape(gt["cam_R_m2c"], (3, 3)), inst["pose"]["rotation"])
            assert np.allclose(
                np.array(gt["cam_t_m2c"]) / 1000.0, inst["pose"]["translation"], atol=1e-8
            )
            name = f"{frame:06d}_{gt_id:06d}.png"
            visib = np.asarray(Image.open(root / "bop/train_pbr/000000/mask_visib" / name))
            whole = np.asarray(Image.open(root / "bop/train_pbr/000000/mask" / name))
            assert int((visib > 0).sum()) == info["px_count_visib"] == inst["visible_px"]
            assert int((whole > 0).sum()) == info["px_count_all"] - int(
                ((visib > 0) & ~(whole > 0)).sum()
            )
            assert info["visib_fract"] == pytest.approx(
                info["px_count_visib"] / max(info["px_count_all"], 1), abs=1e-6
            )
            assert len(info["bbox_obj"]) == len(info["bbox_visib"]) == 4


def assert_first_tile_shows_the_labels(root: Path, sheet: np.ndarray[Any, Any]) -> None:
    """Frame 0's tile (top left, 4 px in) is the raw frame scaled to 320 px wide except where
    masks, boxes and class names are drawn: inside each mask and along each box's top edge the
    pixels moved well away from the raw ones, and away from all of them nothing moved."""
    view = native(root, 0)["views"][0]
    raw = Image.open(root / view["rgb"]).convert("RGB")
    scale = 320 / raw.width
    height = max(round(raw.height * scale), 1)
    plain = np.asarray(raw.resize((320, height), Image.Resampling.BILINEAR)).astype(np.int16)
    tile = sheet[4 : 4 + height, 4 : 4 + 320]
    diff = np.abs(tile - plain).max(axis=2)
    instance = np.load(root / view["labels"])["instance"]
    drawn = np.zeros(instance.shape, dtype=bool)
    assert view["instances"]
    for inst in view["instances"]:
        mask = instance == inst["id"]
        drawn |= mask
        x0, y0, x1, y1 = (int(v) for v in inst["box_tight"])
        drawn[max(y0 - 2, 0) : y1 + 3, max(x0 - 2, 0) : x1 + 3] = True
        text_right = x0 + 4 + 8 * len(inst["class"])  # the default font is 6 px a letter
        drawn[max(y0 - 14, 0) : max(y0 - 14, 0) + 16, max(x0 - 2, 0) : text_right] = True
        small = np.asarray(Image.fromarray(mask).resize((320, height), Image.Resampling.NEAREST))
        inner = small.copy()
        for dy, dx in ((-2, 0), (2, 0), (0, -2), (0, 2)):
            inner &= np.roll(small, (dy, dx), axis=(0, 1))
        if inner.sum() >= 4:
            assert diff[inner].mean() > 20, (inst, diff[inner].mean())
        top = round(y0 * scale)
        edge = diff[top, round(x0 * scale) + 1 : round(x1 * scale)]
        assert edge.size, inst
        assert edge.mean() > 20, (inst, edge)
    near = np.asarray(Image.fromarray(drawn).resize((320, height), Image.Resampling.NEAREST))
    grown = near.copy()
    for dy in range(-3, 4):
        for dx in range(-3, 4):
            grown |= np.roll(near, (dy, dx), axis=(0, 1))
    assert (~grown).sum() > 320 * height // 4
    assert diff[~grown].max() <= 2, diff[~grown].max()


def test_the_contact_sheet_and_dataset_record_are_written(
    dataset: tuple[Path, DatasetSummary],
) -> None:
    root, summary = dataset
    sheet = Image.open(root / "contact_sheet.png")
    assert sheet.mode == "RGB"
    assert sheet.width > 320
    assert_first_tile_shows_the_labels(root, np.asarray(sheet).astype(np.int16))
    meta = json.loads((root / "dataset.json").read_text())
    assert meta["frames"] == FRAMES
    assert [c["name"] for c in meta["classes"]] == ["cube", "can", "distractor"]
    assert summary.instances == sum(
        len(native(root, f)["views"][0]["instances"]) for f in range(FRAMES)
    )
