"""The tutorial's pick and place: 4 trajectories, accurate goals, limits, collisions, speed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simbridge.errors import PlanningError
from simbridge.planning import (
    JointTrajectory,
    MoverOptions,
    MoverPlanner,
    PickAndPlacePlan,
    Pose,
    top_down_orientation,
)
from tests.planning.conftest import TABLE

CUBE_HALF = 0.025  # 5 cm cube resting on the table (z = 0)
PICK_OFFSET = 0.1  # the tutorial's pickPoseOffset above the object


def _random_task(rng: np.random.Generator) -> tuple[Pose, Pose]:
    """Cube and target within reach in front of the robot, at least 8 cm apart."""

    def spot() -> np.ndarray:
        r, th = rng.uniform(0.16, 0.32), rng.uniform(-math.pi / 3, math.pi / 3)
        return np.array([r * math.cos(th), r * math.sin(th), CUBE_HALF])

    cube, target = spot(), spot()
    while np.linalg.norm(cube - target) < 0.08:
        target = spot()
    yaw = rng.uniform(-math.pi / 4, math.pi / 4)
    pick = Pose(cube + np.array([0, 0, PICK_OFFSET]), top_down_orientation(yaw))
    place = Pose(target + np.array([0, 0, PICK_OFFSET]), top_down_orientation(0.0))
    return pick, place


def _pose_error(mover: MoverPlanner, q: np.ndarray, goal: Pose) -> tuple[float, float]:
    pose = mover.kinematics.forward(q)
    cos = (np.trace(goal.rotation.T @ pose.rotation) - 1) / 2
    angle = math.degrees(math.acos(float(np.clip(cos, -1, 1))))
    return float(np.linalg.norm(pose.position - goal.position)), angle


def _dense_collision_free(mover: MoverPlanner, traj: JointTrajectory, step: float = 0.01) -> bool:
    k = mover.kinematics
    for a, b in zip(traj.positions[:-1], traj.positions[1:], strict=True):
        count = max(1, math.ceil(float(np.max(np.abs(b - a))) / step))
        if any(k.in_collision(a + s * (b - a)) for s in np.linspace(0, 1, count + 1)):
            return False
    return True


def _check_plan(
    mover: MoverPlanner, start: np.ndarray, pick: Pose, place: Pose, plan: PickAndPlacePlan
) -> None:
    k = mover.kinematics
    vmax = k.velocity_limits * mover.options.velocity_scale
    amax = k.acceleration_limits * mover.options.acceleration_scale
    previous_end = start
    for traj in plan.trajectories:
        assert traj.joint_names == tuple(f"joint_{i}" for i in range(1, 7))
        np.testing.assert_allclose(traj.start, previous_end, atol=1e-12)
        previous_end = traj.end
        assert traj.times[0] == 0.0
        assert np.all(np.diff(traj.times) > 0)
        assert np.all(np.abs(traj.velocities) <= vmax * (1 + 1e-9))
        assert np.all(np.abs(traj.accelerations) <= amax * (1 + 1e-9))
        assert all(k.within_limits(q) for q in traj.positions)
    for traj in plan.trajectories[:3]:
        assert _dense_collision_free(mover, traj)
    k.hold(True)  # the cube hangs below the fingers while placing
    try:
        assert _dense_collision_free(mover, plan.place)
    finally:
        k.hold(False)
    grasp_goal = pick.translated(dz=-mover.options.grasp_drop)
    for q, goal in (
        (plan.pre_grasp.end, pick),
        (plan.grasp.end, grasp_goal),
        (plan.pick_up.end, pick),
        (plan.place.end, place),
    ):
        position_error, angle_error = _pose_error(mover, q, goal)
        assert position_error < 1e-3
        assert angle_error < 1.0
    # grasp and pick up move the tool along the vertical line through the cube
    for q in np.vstack([plan.grasp.positions, plan.pick_up.positions]):
        p = k.forward(q).position
        assert np.linalg.norm(p[:2] - pick.position[:2]) < 3e-3


def test_tutorial_scene(mover: MoverPlanner) -> None:
    """Cube 25 cm ahead and 10 cm left, target 15 cm right, starting from all zeros."""
    start = np.zeros(6)
    pick = Pose([0.25, 0.1, CUBE_HALF + PICK_OFFSET], top_down_orientation(0.2))
    place = Pose([0.2, -0.15, CUBE_HALF + PICK_OFFSET], top_down_orientation(0.0))
    plan = mover.plan(start, pick, place)
    _check_plan(mover, start, pick, place, plan)
    assert plan.planning_time > 0  # its speed: benchmarks/bench_pick_and_place.py, "plan"


def test_twenty_random_tasks_all_succeed(mover: MoverPlanner) -> None:
    rng = np.random.default_rng(2024)
    successes = 0
    for _ in range(20):  # each search is bounded by samples (PathOptions.max_samples), not time
        pick, place = _random_task(rng)
        plan = mover.plan(np.zeros(6), pick, place)
        _check_plan(mover, np.zeros(6), pick, place, plan)
        successes += 1
    assert successes == 20


def test_deterministic(mover: MoverPlanner) -> None:
    pick, place = _random_task(np.random.default_rng(9))
    first = mover.plan(np.zeros(6), pick, place)
    again = MoverPlanner.niryo_one([TABLE]).plan(np.zeros(6), pick, place)
    for a, b in zip(first.trajectories, again.trajectories, strict=True):
        np.testing.assert_array_equal(a.times, b.times)
        np.testing.assert_array_equal(a.positions, b.positions)


def test_unreachable_place_names_the_goal(mover: MoverPlanner) -> None:
    pick = Pose([0.25, 0.0, 0.125], top_down_orientation())
    with pytest.raises(PlanningError, match=r"place \(place_pose\) \(x=0\.900.*unreachable"):
        mover.plan(np.zeros(6), pick, Pose([0.9, 0.0, 0.125], top_down_orientation()))


def test_pick_inside_the_table_is_a_collision(mover: MoverPlanner) -> None:
    with pytest.raises(PlanningError, match=r"pre-grasp \(pick_pose\).*collision: table"):
        mover.plan(
            np.zeros(6), Pose([0.25, 0.0, 0.03], top_down_orientation()), Pose([0.2, 0.1, 0.15])
        )


def test_grasp_that_would_hit_the_table_fails(mover: MoverPlanner) -> None:
    # pre-grasp 6 cm up: the 5 cm descent puts the fingertips into the table
    with pytest.raises(PlanningError, match="grasp"):
        mover.plan(
            np.zeros(6),
            Pose([0.25, 0.0, 0.06 + 0.05], top_down_orientation()),
            Pose([0.2, 0.1, 0.15], top_down_orientation()),
        )


def test_bad_start_is_rejected(mover: MoverPlanner) -> None:
    pick, place = _random_task(np.random.default_rng(1))
    with pytest.raises(PlanningError, match="expected 6 start joint values"):
        mover.plan([0.0] * 5, pick, place)
    with pytest.raises(PlanningError, match=r"joint_3 = 2\.0000 rad is outside"):
        mover.plan([0, 0, 2.0, 0, 0, 0], pick, place)


def test_option_validation() -> None:
    with pytest.raises(PlanningError, match=r"velocity_scale must be in \(0, 1\]"):
        MoverOptions(velocity_scale=1.5)
    with pytest.raises(PlanningError, match="grasp_symmetry must be >= 1"):
        MoverOptions(grasp_symmetry=0)


def test_turned_grasp_when_joint_6_runs_out(mover: MoverPlanner) -> None:
    """Yaw 180 deg needs joint_6 beyond +-2.57 rad; the two-finger grasp turned by 180 deg works."""
    pick = Pose([0.25, 0.0, 0.125], top_down_orientation(math.pi))
    place = Pose([0.2, 0.15, 0.125], top_down_orientation(0.0))
    strict = MoverPlanner(mover.kinematics, MoverOptions(grasp_symmetry=1))
    with pytest.raises(PlanningError, match=r"pre-grasp \(pick_pose\).*unreachable"):
        strict.plan(np.zeros(6), pick, place)
    plan = mover.plan(np.zeros(6), pick, place)
    reached = mover.kinematics.forward(plan.pre_grasp.end)
    np.testing.assert_allclose(reached.position, pick.position, atol=1e-3)
    # same approach axis (down), fingers swapped: tool y flipped
    np.testing.assert_allclose(reached.rotation[:, 0], pick.rotation[:, 0], atol=1e-3)
    np.testing.assert_allclose(reached.rotation[:, 1], -pick.rotation[:, 1], atol=1e-3)
