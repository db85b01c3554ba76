"""The same seed gives the same files byte for byte whichever frames a process renders, in
whatever order, alone or among others, and however the frames are split into shards."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from simbridge.perception import DatagenJob, generate, merge_shards, render_frames
from tests.perception.scenes import random_scene

SHARD = """
import sys
from pathlib import Path
from simbridge.perception import DatagenJob, render_frames
job = DatagenJob(sys.argv[1], seed=11, formats=("coco", "bop"))
render_frames(job, [int(f) for f in sys.argv[3].split(",")], Path(sys.argv[2]))
"""


def render_in_fresh_processes(scene: Path, shards: dict[Path, list[int]]) -> None:
    """Render each shard's frames in a fresh process of its own (all at once)."""
    env = dict(os.environ)
    env.setdefault("MUJOCO_GL", "osmesa")
    env.setdefault("PYOPENGL_PLATFORM", env["MUJOCO_GL"])
    runs = [
        subprocess.Popen(
            [sys.executable, "-c", SHARD, str(scene), str(out), ",".join(map(str, frames))],
            env=env,
        )
        for out, frames in shards.items()
    ]
    for run in runs:
        assert run.wait(timeout=300) == 0


def files(root: Path, frame: int | None = None) -> dict[str, bytes]:
    """Every file under `root` (of frame `frame` alone when given) by relative path."""
    found = {}
    for path in sorted(root.rglob("*")):
        if path.is_file() and (frame is None or path.name.startswith(f"{frame:06d}")):
            found[str(path.relative_to(root))] = path.read_bytes()
    return found


def test_a_frame_rendered_alone_is_the_frame_rendered_after_others(tmp_path: Path) -> None:
    scene = random_scene(tmp_path)
    render_in_fresh_processes(scene, {tmp_path / "alone": [3], tmp_path / "after": [0, 1, 2, 3]})
    alone, after = files(tmp_path / "alone", 3), files(tmp_path / "after", 3)
    assert len(alone) >= 4  # RGB, label arrays and JSON, BOP's RGB, depth and masks
    assert sorted(alone) == sorted(after)
    for name, data in alone.items():
        assert data == after[name], name
    # Frames differ from each other (the randomisers ran): frame 2 is not frame 3.
    assert files(tmp_path / "after", 2)["native/main/000002.png"] != alone["native/main/000003.png"]


def test_shards_merge_into_the_dataset_one_process_makes(tmp_path: Path) -> None:
    scene = random_scene(tmp_path)
    job = DatagenJob(str(scene), seed=11, formats=("coco", "bop"))
    whole = generate(job, 4, tmp_path / "whole")
    render_frames(job, [3, 1], tmp_path / "b")
    render_frames(job, [2, 0], tmp_path / "a")
    merged = merge_shards(job, [tmp_path / "a", tmp_path / "b"], tmp_path / "merged", 4)
    assert merged.annotations == whole.annotations > 0
    assert_same_files(tmp_path / "whole", tmp_path / "merged")


@pytest.mark.slow  # spawns two processes; the fresh-process test above is the fast check
def test_workers_make_the_dataset_one_process_makes(tmp_path: Path) -> None:
    job = DatagenJob(str(random_scene(tmp_path)), seed=11, formats=("coco", "bop"))
    whole = generate(job, 4, tmp_path / "whole")
    spread = generate(job, 4, tmp_path / "spread", workers=2)
    assert spread.annotations == whole.annotations
    assert_same_files(tmp_path / "whole", tmp_path / "spread")


def assert_same_files(left_root: Path, right_root: Path) -> None:
    left, right = files(left_root), files(right_root)
    assert sorted(left) == sorted(right)
    for name, data in left.items():
        assert data == right[name], name
