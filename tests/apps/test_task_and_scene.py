"""Pick-and-place tasks, poses, message conversion, the scene file and video output."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from simbridge.apps.pick_and_place import (
    SCENE_PATH,
    PickAndPlaceTask,
    build_world,
    planning_obstacles,
)
from simbridge.apps.pick_and_place.conversion import (
    pose_from_msg,
    pose_to_msg,
    robot_trajectory_msg,
    sim_trajectory,
)
from simbridge.apps.pick_and_place.scene import FINGER_GEOMS, TARGET_MARKER
from simbridge.apps.pick_and_place.video import VideoRecorder, check_video_path
from simbridge.errors import AppError
from simbridge.messages import default_registry
from simbridge.planning import BoxObstacle, JointTrajectory, Pose, top_down_orientation
from simbridge.sim import load_scene

REG = default_registry()
QUARTER = math.pi / 2


def angle_gap(a: float, b: float, period: float) -> float:
    """Distance between two angles modulo ``period``."""
    d = (a - b) % period
    return min(d, period - d)


@settings(max_examples=60, deadline=None)
@given(st.integers(min_value=0, max_value=2**32 - 1))
def test_random_tasks_are_reachable_separate_and_repeatable(seed: int) -> None:
    task = PickAndPlaceTask.random(seed)
    assert task == PickAndPlaceTask.random(seed)
    for x, y in (task.cube_xy, task.target_xy):
        assert 0.17 <= math.hypot(x, y) <= 0.30
        assert abs(math.atan2(y, x)) <= math.radians(70)
    assert math.dist(task.cube_xy, task.target_xy) >= 0.10
    assert abs(task.cube_yaw) <= math.pi / 4
    # the gripper squares up to the cube's faces and stays within 45 deg of the bearing
    assert angle_gap(task.grasp_yaw(), task.cube_yaw, QUARTER) < 1e-9
    bearing = math.atan2(task.cube_xy[1], task.cube_xy[0])
    assert abs(task.grasp_yaw() - bearing) <= math.pi / 4 + 1e-9
    assert angle_gap(task.release_yaw(), task.target_yaw, QUARTER) < 1e-9


def test_pick_and_place_poses_point_down_at_the_right_heights() -> None:
    task = PickAndPlaceTask(cube_xy=(0.2, 0.0), cube_yaw=0.0, target_xy=(0.0, 0.25))
    pick = task.pick_pose(grasp_offset=0.05)
    # cube centre 0.025 + pads 0.05 below the tool + the tutorial's 5 cm above the grasp
    assert pick.position == pytest.approx([0.2, 0.0, 0.125])
    assert pick.rotation[:, 0] == pytest.approx([0.0, 0.0, -1.0])  # approach axis down
    assert pick.rotation[:, 1] == pytest.approx([0.0, 1.0, 0.0])  # fingers slide along y
    place = task.place_pose(grasp_offset=0.05)
    assert place.position == pytest.approx([0.0, 0.25, 0.025 + 0.05 + task.place_clearance])
    # at bearing 90 deg the release yaw turns the fingers to slide along -x
    assert place.rotation[:, 1] == pytest.approx([-1.0, 0.0, 0.0])


def test_out_of_reach_task_is_refused() -> None:
    with pytest.raises(AppError, match=r"cube_xy=\(0\.6, 0\.0\)"):
        PickAndPlaceTask(cube_xy=(0.6, 0.0))


def test_trajectory_message_round_trip_keeps_times_and_points() -> None:
    names = tuple(f"joint_{i}" for i in range(1, 7))
    positions = np.linspace(0.0, 1.0, 18).reshape(3, 6)
    velocities = np.vstack([np.zeros(6), np.full(6, 0.4), np.zeros(6)])
    trajectory = JointTrajectory(
        names, np.array([0.0, 0.5, 1.25]), positions, velocities, np.zeros((3, 6))
    )
    msg = robot_trajectory_msg(REG, trajectory)
    stamps = [
        (p.time_from_start.sec, p.time_from_start.nanosec) for p in msg.joint_trajectory.points
    ]
    assert stamps == [(0, 0), (0, 500_000_000), (1, 250_000_000)]
    wire = REG.decode(REG.encode(msg), "moveit_msgs/RobotTrajectory")
    sim = sim_trajectory(wire)
    assert sim.joints == names
    assert [p.time for p in sim.points] == pytest.approx([0.0, 0.5, 1.25])
    assert np.array([p.positions for p in sim.points]) == pytest.approx(positions)
    assert np.array([p.velocities for p in sim.points]) == pytest.approx(velocities)


def test_empty_trajectory_message_is_an_app_error() -> None:
    with pytest.raises(AppError, match="no joints or no points"):
        sim_trajectory(REG.new("moveit_msgs/RobotTrajectory"))


def test_pose_message_round_trip() -> None:
    pose = Pose([0.1, -0.2, 0.3], top_down_orientation(0.7))
    back = pose_from_msg(pose_to_msg(REG, pose))
    assert back.position == pytest.approx(pose.position)
    assert back.orientation == pytest.approx(pose.orientation)


def test_planning_scene_is_the_table_from_the_scene_file() -> None:
    obstacles = planning_obstacles(load_scene(SCENE_PATH))
    assert obstacles == [
        BoxObstacle("table", (0.15, 0.0, -0.02), (0.4, 0.6, 0.02), (0.0, 0.0, 0.0, 1.0))
    ]


def test_planning_needs_the_robot_at_the_origin() -> None:
    scene = load_scene(SCENE_PATH)
    robot = dataclasses.replace(
        scene.robots[0], base=dataclasses.replace(scene.robots[0].base, xyz=(0.1, 0.0, 0.0))
    )
    with pytest.raises(AppError, match="world origin"):
        planning_obstacles(dataclasses.replace(scene, robots=(robot,)))


def test_world_puts_cube_and_target_where_the_task_says() -> None:
    task = PickAndPlaceTask(cube_xy=(0.25, -0.05), cube_yaw=0.4, target_xy=(0.1, 0.2))
    world = build_world(task)
    model, data = world.model, world.data
    assert data.xpos[model.body("cube").id] == pytest.approx(task.cube_center)
    x_axis = data.xmat[model.body("cube").id].reshape(3, 3)[:, 0]
    assert math.atan2(x_axis[1], x_axis[0]) == pytest.approx(0.4)
    marker = model.geom(TARGET_MARKER)
    assert marker.contype[0] == 0  # drawn, never touched
    assert marker.conaffinity[0] == 0
    assert data.geom_xpos[marker.id][:2] == pytest.approx(task.target_xy)
    for name in ("cube", *FINGER_GEOMS):
        assert model.geom(name).condim[0] == 4


def test_video_path_checks(tmp_path: Path) -> None:
    with pytest.raises(AppError, match=r"'\.avi'.*\.gif, \.mp4"):
        check_video_path(tmp_path / "run.avi")
    with pytest.raises(AppError, match="does not exist"):
        check_video_path(tmp_path / "missing" / "run.gif")
    assert check_video_path(tmp_path / "run.gif") == tmp_path / "run.gif"
    # imageio-ffmpeg (a dependency) ships an ffmpeg, so MP4 is always possible.
    assert check_video_path(tmp_path / "run.mp4") == tmp_path / "run.mp4"


def test_mp4_is_written(tmp_path: Path) -> None:
    world = build_world(PickAndPlaceTask())
    recorder = VideoRecorder(world, tmp_path / "run.mp4", fps=50, width=64, height=48)
    recorder.maybe_capture()
    while world.time < 0.1 - 1e-9:
        world.step()
        recorder.maybe_capture()
    path = recorder.save()
    head = path.read_bytes()[:12]
    assert head[4:8] == b"ftyp"  # an ISO base media (MP4) file


def test_gif_frames_follow_sim_time(tmp_path: Path) -> None:
    world = build_world(PickAndPlaceTask())
    recorder = VideoRecorder(world, tmp_path / "run.gif", fps=50, width=64, height=48)
    recorder.maybe_capture()
    while world.time < 0.1 - 1e-9:
        world.step()
        recorder.maybe_capture()
    assert recorder.frame_count == 6  # t = 0, 0.02, ..., 0.1
    path = recorder.save()
    with Image.open(path) as image:
        assert image.format == "GIF"
        assert image.size == (64, 48)
        pixels = np.asarray(image.convert("RGB"), dtype=np.float64)
    assert pixels.mean() > 20  # a lit scene, not a black frame
