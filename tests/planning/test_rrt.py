"""Joint-space planning: RRT-Connect around a wall, dense collision checks, determinism."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from simbridge.assets import robot_urdf
from simbridge.errors import PlanningError
from simbridge.planning import (
    ArmKinematics,
    BoxObstacle,
    IKSolver,
    JointPathPlanner,
    PathOptions,
    Pose,
    build_planning_model,
    niryo_one_arm,
    top_down_orientation,
)
from tests.planning.conftest import TABLE

WALL = BoxObstacle("wall", center=(0.25, 0.0, 0.15), half_extents=(0.03, 0.06, 0.15))


@pytest.fixture(scope="module")
def walled() -> ArmKinematics:
    return ArmKinematics(build_planning_model(robot_urdf(), [TABLE, WALL]), niryo_one_arm())


@pytest.fixture(scope="module")
def ends(walled: ArmKinematics) -> tuple[np.ndarray, np.ndarray]:
    ik = IKSolver(walled)
    start = ik.solve(Pose([0.12, 0.22, 0.1], top_down_orientation()), np.zeros(6))
    goal = ik.solve(Pose([0.12, -0.22, 0.1], top_down_orientation()), np.zeros(6))
    return start, goal


def _dense_free(k: ArmKinematics, path: np.ndarray, step: float = 0.005) -> bool:
    for a, b in itertools.pairwise(path):
        count = max(1, int(np.ceil(np.max(np.abs(b - a)) / step)))
        for s in np.linspace(0.0, 1.0, count + 1):
            if k.in_collision(a + s * (b - a)):
                return False
    return True


def test_straight_line_when_free(kinematics: ArmKinematics) -> None:
    planner = JointPathPlanner(kinematics)
    start, goal = np.zeros(6), np.array([0.5, -0.3, 0.2, 0.0, -0.4, 0.1])
    path = planner.plan(start, goal)
    np.testing.assert_array_equal(path, np.vstack([start, goal]))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rrt_connect_goes_around_the_wall(
    walled: ArmKinematics, ends: tuple[np.ndarray, np.ndarray], seed: int
) -> None:
    start, goal = ends
    planner = JointPathPlanner(walled)
    assert not planner.edge_free(start, goal)  # the direct sweep hits the wall
    path = planner.plan(start, goal, seed=seed)
    np.testing.assert_array_equal(path[0], start)
    np.testing.assert_array_equal(path[-1], goal)
    assert len(path) >= 3
    assert all(walled.within_limits(q) for q in path)
    assert _dense_free(walled, path)


def test_same_seed_same_path(walled: ArmKinematics, ends: tuple[np.ndarray, np.ndarray]) -> None:
    planner = JointPathPlanner(walled, PathOptions(seed=5))
    np.testing.assert_array_equal(planner.plan(*ends), planner.plan(*ends))


def test_shortcutting_shortens(walled: ArmKinematics, ends: tuple[np.ndarray, np.ndarray]) -> None:
    def length(path: np.ndarray) -> float:
        return float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))

    raw = JointPathPlanner(walled, PathOptions(shortcut_attempts=0, seed=3))
    short = JointPathPlanner(walled, PathOptions(shortcut_attempts=60, seed=3))
    assert length(short.plan(*ends)) <= length(raw.plan(*ends)) + 1e-9


def test_colliding_start_and_goal_are_rejected(walled: ArmKinematics) -> None:
    planner = JointPathPlanner(walled)
    into_table = np.array([3.0, -1.5, 0.3, 0, 0, 0])  # reaching backwards, away from the wall
    with pytest.raises(PlanningError, match=r"start configuration is in collision: table <-> "):
        planner.plan(into_table, np.zeros(6))
    with pytest.raises(PlanningError, match=r"place configuration is in collision"):
        planner.plan(np.zeros(6), into_table, name="place")
    with pytest.raises(PlanningError, match="outside its limits"):
        planner.plan(np.zeros(6), np.array([0, 0, 3.0, 0, 0, 0]))


def test_sample_budget_exhaustion_fails_cleanly(
    walled: ArmKinematics, ends: tuple[np.ndarray, np.ndarray]
) -> None:
    """When the budget runs out the planner stops with a clear error instead of hanging."""
    planner = JointPathPlanner(walled, PathOptions(max_samples=2))
    with pytest.raises(
        PlanningError, match="no collision-free path to far side found after 2 samples"
    ):
        planner.plan(*ends, name="far side")
