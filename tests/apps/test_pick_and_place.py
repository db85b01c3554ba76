"""Pick and place end to end on the local backend: endpoint, planner node, simulator."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from simbridge.apps.pick_and_place import (
    SCENE_PATH,
    PickAndPlaceResult,
    PickAndPlaceTask,
    build_world,
    main,
    run_pick_and_place,
)
from simbridge.apps.pick_and_place.sim_side import STAGES
from simbridge.apps.summary import SUMMARY_KEYS

PHASES = (
    "settle",
    "plan",
    "pre_grasp",
    "grasp",
    "close_gripper",
    "pick_up",
    "place",
    "open_gripper",
    "release",
)


@pytest.fixture(scope="module")
def default_run() -> tuple[PickAndPlaceResult, str]:
    lines: list[str] = []
    result = run_pick_and_place("local", progress=lines.append)
    return result, "\n".join(lines)


def test_cube_ends_on_the_target_upright(default_run: tuple[PickAndPlaceResult, str]) -> None:
    result, _ = default_run
    assert result.error is None
    assert result.success
    assert result.trajectories == len(STAGES)
    assert result.cube_error_m < 0.02
    assert math.dist(result.cube_final, result.target) == pytest.approx(result.cube_error_m)
    assert result.upright
    # resting on the table: its centre half a cube above the top
    assert result.cube_final[2] == pytest.approx(0.025, abs=0.002)


def test_phases_in_order_and_faster_than_real_time(
    default_run: tuple[PickAndPlaceResult, str],
) -> None:
    result, progress = default_run
    assert tuple(p.name for p in result.phases) == PHASES
    assert all(p.sim_s >= 0 and p.wall_s >= 0 for p in result.phases)
    moving = sum(p.sim_s for p in result.phases if p.name in STAGES)
    assert moving > 3.0  # four real motions were followed, not skipped
    assert result.sim_time > result.wall_time
    for name in PHASES:
        assert f"[pick-and-place] {name}" in progress


def test_cube_moved_continuously_and_only_after_the_gripper_closed(
    default_run: tuple[PickAndPlaceResult, str],
) -> None:
    result, _ = default_run
    track = result.cube_track
    assert track.shape[0] > 1000
    times, positions = track[:, 0], track[:, 1:]
    assert np.all(np.diff(times) > 0)
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    # 2 ms steps: 4 mm per step would be 2 m/s, far above anything the arm does
    assert steps.max() < 0.004
    assert result.gripper_closed_at is not None
    before = positions[times < result.gripper_closed_at]
    start = np.array(result.cube_start)
    assert np.linalg.norm(before - start, axis=1).max() < 0.003
    lifted = times[positions[:, 2] > result.cube_start[2] + 0.03]
    assert lifted.size > 0
    assert lifted.min() > result.gripper_closed_at
    assert np.allclose(positions[-1], result.cube_final)


def test_the_cube_is_free_and_never_welded() -> None:
    world = build_world(PickAndPlaceTask())
    model = world.model
    # the only equality is the URDF's finger mimic; the cube hangs on a free joint
    assert model.neq == 1
    assert model.eq(0).name == "right_finger_joint/mimic"
    cube = model.body("cube")
    assert model.jnt_type[cube.jntadr[0]] == 0  # mjJNT_FREE
    assert model.body_weldid[cube.id] == cube.id


def test_json_summary_is_the_last_line(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["--json", "--seed", "7"])
    lines = capsys.readouterr().out.strip().splitlines()
    summary = json.loads(lines[-1])
    assert code == 0
    assert summary["success"] is True
    assert summary["cube_error_m"] < 0.02
    assert [p["name"] for p in summary["phases"]] == list(PHASES)
    assert summary["seed"] == 7
    assert list(summary)[:7] == list(SUMMARY_KEYS)
    task = PickAndPlaceTask.random(7)
    assert summary["target"] == pytest.approx(task.target_center, abs=1e-4)


def test_bad_video_path_fails_before_running(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--video", "run.avi"]) == 2
    assert "'.avi'" in capsys.readouterr().err


def test_blocked_pick_ends_with_the_planners_reason(tmp_path: Path) -> None:
    scene = yaml.safe_load(SCENE_PATH.read_text())
    robot = scene["robots"][0]
    robot["urdf"] = str((SCENE_PATH.parent / robot["urdf"]).resolve())
    # a shelf just above the default cube: the planner must refuse the pre-grasp pose
    shelf = {"name": "shelf", "type": "box", "size": [0.3, 0.3, 0.02]}
    scene["objects"].append({**shelf, "pose": {"xyz": [0.22, 0.12, 0.09]}})
    path = tmp_path / "blocked.yaml"
    path.write_text(yaml.safe_dump(scene))
    result = run_pick_and_place("local", scene=path, progress=None)
    assert not result.success
    assert result.trajectories == 0
    assert result.error is not None
    assert "pick_pose" in result.error
    assert "shelf" in result.error
    assert [p.name for p in result.phases] == ["settle", "plan"]
    assert result.cube_final == pytest.approx(result.cube_start, abs=1e-3)
