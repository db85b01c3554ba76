"""`simbridge demo datagen` run for real (the shipped pick-and-place scene) at its smallest
frame count into a test folder: COCO, BOP and the contact sheet are written and the COCO
file loads in pycocotools with annotations."""

from __future__ import annotations

import json
from pathlib import Path

from pycocotools.coco import COCO  # type: ignore[import-untyped]

from simbridge.cli import main


def test_demo_datagen_writes_coco_bop_and_contact_sheet(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    argv = ["demo", "datagen", "--frames", "1", "--out", str(out), "--seed", "3"]
    assert main([*argv, "--quality", "fast", "--workers", "1"]) == 0
    assert (out / "dataset.json").is_file()
    assert (out / "contact_sheet.png").stat().st_size > 0
    assert (out / "native" / "frames" / "000000.json").is_file()
    assert (out / "bop" / "camera.json").is_file()
    scenes = list((out / "bop" / "train_pbr").glob("*/scene_gt.json"))
    assert scenes, f"no BOP scene_gt.json under {out / 'bop' / 'train_pbr'}"
    assert json.loads(scenes[0].read_text())["0"], "BOP frame 0 has no objects"
    coco = COCO(str(out / "coco" / "annotations.json"))
    images = coco.getImgIds()
    assert len(images) >= 1
    annotations = coco.loadAnns(coco.getAnnIds(imgIds=images))
    assert annotations, "COCO has no annotations"
    for annotation in annotations:
        assert annotation["category_id"] in coco.getCatIds()
        assert int(coco.annToMask(annotation).sum()) > 0
