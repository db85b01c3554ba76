"""`simbridge datagen` and `simbridge demo datagen`: the dataset, the summary line,
`--resume` from the first missing frame (same bytes as a run without a break), and errors
that name the file, line and entry of a bad `perception:` section."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

from simbridge.cli import build_parser, main
from simbridge.perception.dataset import ENCODING
from tests.perception.scenes import random_scene

SUMMARY = re.compile(
    r"datagen: (\d+) frames \((\d+) rendered now, [\d.]+ frames/s, 1 worker\), (\d+) images, "
    r"(\d+) COCO annotations, (\d+) labelled instances of random\.yaml seed 4 -> .* in "
)


def files(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


def datagen(scene: Path, out: Path, frames: int, *extra: str) -> int:
    return main(["datagen", str(scene), "--frames", str(frames), "--out", str(out),
                 "--format", "coco,bop,native", "--seed", "4", *extra])  # fmt: skip


def test_datagen_writes_the_dataset_and_resumes_at_the_first_missing_frame(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = random_scene(tmp_path)
    assert datagen(scene, tmp_path / "whole", 3) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    found = SUMMARY.match(line)
    assert found, line
    assert found.group(1, 2, 3) == ("3", "3", "3")
    whole = files(tmp_path / "whole")
    assert {"coco/annotations.json", "contact_sheet.png", "dataset.json"} <= set(whole)
    assert "bop/train_pbr/000000/scene_gt.json" in whole
    # A run cut short after frame 0 (frame 1's JSON never written) continues at frame 1.
    assert datagen(scene, tmp_path / "cut", 1) == 0
    (tmp_path / "cut" / "native/frames/000000.json").rename(tmp_path / "frame0.json")
    assert datagen(scene, tmp_path / "cut", 3, "--resume") == 0  # frame 0 missing: all 3
    (tmp_path / "cut" / "native/frames/000001.json").unlink()
    (tmp_path / "cut" / "native/frames/000002.json").unlink()
    capsys.readouterr()
    assert datagen(scene, tmp_path / "cut", 3, "--resume") == 0
    found = SUMMARY.match(capsys.readouterr().out.strip().splitlines()[-1])
    assert found
    assert found.group(1, 2) == ("3", "2")
    assert files(tmp_path / "cut") == whole


def test_datagen_refuses_to_resume_a_dataset_another_version_encoded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Written before `encoding` existed (its dataset.json without it): the same frames
    # would now come out as other bytes, so continuing would mix two encodings.
    scene = random_scene(tmp_path)
    assert datagen(scene, tmp_path / "out", 1) == 0
    meta = tmp_path / "out" / "native" / "dataset.json"
    document = json.loads(meta.read_text())
    assert document["encoding"] == ENCODING
    del document["encoding"]
    meta.write_text(json.dumps(document))
    capsys.readouterr()
    assert datagen(scene, tmp_path / "out", 2, "--resume") == 2
    error = capsys.readouterr().err
    assert f"another version of simbridge (file encoding 1, this version writes {ENCODING}" in error
    assert "render it again into a new folder" in error
    # A dataset.json that is not datagen's JSON is named, with what is wrong with it.
    meta.write_text('{"schema": "simbridge-perception/1",')
    assert datagen(scene, tmp_path / "out", 2, "--resume") == 2
    error = capsys.readouterr().err
    assert f"'{meta}': Expecting property name" in error
    assert "line 1 column" in error
    meta.write_text("[]")
    assert datagen(scene, tmp_path / "out", 2, "--resume") == 2
    assert "holds a JSON list, not the object datagen writes" in capsys.readouterr().err


def test_datagen_refuses_to_overwrite_or_resume_another_dataset(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = random_scene(tmp_path)
    assert datagen(scene, tmp_path / "out", 1) == 0
    capsys.readouterr()
    assert datagen(scene, tmp_path / "out", 2) == 2
    assert "already holds a dataset; pass --resume" in capsys.readouterr().err
    assert main(["datagen", str(scene), "--frames", "2", "--out", str(tmp_path / "out"),
                 "--seed", "5", "--resume"]) == 2  # fmt: skip
    assert "cannot be resumed with these options" in capsys.readouterr().err
    # The scene renders at `high` (its default): a `fast` dataset is another dataset.
    assert datagen(scene, tmp_path / "out", 2, "--resume", "--quality", "fast") == 2
    assert "cannot be resumed with these options" in capsys.readouterr().err
    assert datagen(scene, tmp_path / "out", 2, "--resume", "--quality", "high") == 0
    assert datagen(scene, tmp_path / "other", 1, "--format", "coco,yolo") == 2
    assert "unknown format 'yolo'" in capsys.readouterr().err
    assert main(["datagen", "pick-and-placee", "--frames", "1", "--out", str(tmp_path)]) == 2
    assert "did you mean 'pick-and-place'" in capsys.readouterr().err


BAD = [
    ("  cameras:\n    - {name: main, widht: 64}\n",
     r"bad\.yaml:6: perception\.cameras\[0\]\.widht: unknown key 'widht'; did you mean 'width'"),
    ("  cameras: [{name: main}]\n  labelers: [rgb, dpeth]\n",
     r"bad\.yaml:6: perception\.labelers: unknown labeler 'dpeth'; did you mean 'depth'"),
    ("  cameras: [{name: main}]\n  randomizers:\n    - type: lights\n      intensity: [0.9, 0.1]\n",
     r"bad\.yaml:8: perception\.randomizers\[0\]\.intensity: low 0\.9 is above high 0\.1"),
    ("  cameras: [{name: main}]\n  randomizers:\n    - {type: light}\n",
     r"bad\.yaml:7: perception\.randomizers\[0\]\.type: unknown randomizer type 'light'; did you"),
    ("  cameras: [{name: main}]\n  randomizers:\n    - {type: placement, objects: [cube],"
     " surface: table}\n",
     r"bad\.yaml:7: perception\.randomizers\[0\]: objects: no body matches \['cube'\] "
     r"\(bodies: table\)"),
    ("  cameras: [{name: main}]\n  render: {near: 1, far: 0.5}\n",
     r"bad\.yaml:6: perception\.render\.far: far 0\.5 must be beyond near 1"),
    ("  cameras: [{name: main}]\n  render: {quality: hihg}\n",
     r"bad\.yaml:6: perception\.render\.quality: expected one of high, balanced, fast, got "
     r"'hihg'; did you mean 'high'"),
    ("  cameras: [{name: main}]\n  render: {shadow_size: 20}\n",
     r"bad\.yaml:6: perception\.render\.shadow_size: 20 is out of range "
     r"\(expected \[64, 16384\]\)"),
    ("  cameras: [{name: main}]\n  render: {shadow_size: big}\n",
     r"bad\.yaml:6: perception\.render\.shadow_size: expected a whole number, got"),
]  # fmt: skip


@pytest.mark.parametrize(("section", "expected"), BAD)
def test_a_bad_perception_section_is_named_by_file_line_and_entry(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], section: str, expected: str
) -> None:
    scene = tmp_path / "bad.yaml"
    scene.write_text(
        "ros: {enabled: false}\nobjects:\n  - {name: table, type: box, size: [1, 1, 0.1]}\n"
        "perception:\n" + section
    )
    assert main(["datagen", str(scene), "--frames", "1", "--out", str(tmp_path / "o")]) == 2
    assert re.search(expected, capsys.readouterr().err)
    assert not (tmp_path / "o").exists()


def test_demo_datagen_is_the_shipped_table_at_200_frames() -> None:
    args = build_parser().parse_args(["demo", "datagen"])
    assert (args.frames, args.format, args.seed, args.resume) == (200, "coco,bop", 0, False)
    assert args.workers == (os.cpu_count() or 1)  # one per CPU
    assert args.quality is None  # the scene's: fast
    from simbridge.cli.datagen import scene_path
    from simbridge.perception import FrameMaker

    maker = FrameMaker(scene_path("pick-and-place"))
    try:
        assert {i.category for i in maker.table.instances} == {"cube", "can", "robot", "distractor"}
        assert maker.config.output.contact_sheet > 0
        render = maker.config.render
        assert (render.shadows, render.multisamples) == (False, 0)  # quality: fast
    finally:
        maker.close()
    assert build_parser().parse_args(["demo", "datagen", "--quality", "high"]).quality == "high"


def test_quality_presets_change_the_look_not_the_labels(tmp_path: Path) -> None:
    from simbridge.perception import FrameMaker

    scene = random_scene(tmp_path, size=(96, 72))
    frames = {}
    for quality in ("fast", "balanced", "high"):
        maker = FrameMaker(scene, seed=2, quality=quality)
        try:
            render = maker.config.render
            assert render.shadows == (quality != "fast")
            assert (render.multisamples > 0) == (quality == "high")
            shadow_map = {"balanced": 2048}.get(quality, 4096)  # MuJoCo's default: 4096
            assert maker.world.model.vis.quality.shadowsize == shadow_map
            frames[quality] = maker.make(1).views[0]
        finally:
            maker.close()
    fast, high = frames["fast"], frames["high"]
    assert fast.rgb is not None
    assert high.rgb is not None
    assert not np.array_equal(fast.rgb, high.rgb)
    assert fast.labels.instance_image is not None
    for name, other in frames.items():  # the same labels at every quality
        assert other.labels.instance_image is not None, name
        assert np.array_equal(other.labels.instance_image, fast.labels.instance_image), name
    assert fast.labels.instance_image is not None
    assert high.labels.instance_image is not None
    assert np.array_equal(fast.labels.instance_image, high.labels.instance_image)
    assert fast.labels.category_image is not None
    assert high.labels.category_image is not None
    assert np.array_equal(fast.labels.category_image, high.labels.category_image)
    assert [i.tight_box for i in fast.labels.instances] == [
        i.tight_box for i in high.labels.instances
    ]
    assert fast.depth is not None
    assert high.depth is not None
    assert np.array_equal(fast.depth, high.depth)


@pytest.mark.parametrize(
    ("render", "expected"),
    [
        ("{quality: balanced}", (True, 0, 2048)),
        ("{quality: balanced, shadow_size: 1024}", (True, 0, 1024)),
        ("{quality: high, multisamples: 2}", (True, 2, None)),
        ("{quality: fast, shadows: true, shadow_size: 512}", (True, 0, 512)),
    ],
)
def test_a_scenes_render_keys_win_over_its_preset(
    tmp_path: Path, render: str, expected: tuple[bool, int, int | None]
) -> None:
    from simbridge.perception.config import parse_perception
    from simbridge.sim import load_scene

    scene = tmp_path / "scene.yaml"
    scene.write_text(
        "ros: {enabled: false}\nobjects:\n  - {name: table, type: box, size: [1, 1, 0.1]}\n"
        f"perception:\n  cameras: [{{name: main}}]\n  render: {render}\n"
    )
    settings = parse_perception(load_scene(scene)).render
    assert (settings.shadows, settings.multisamples, settings.shadow_size) == expected
