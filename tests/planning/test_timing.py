"""Trapezoidal time parameterisation: hand-computed durations, limits, synchronisation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.errors import PlanningError
from simbridge.planning import time_parameterize

ONE = ("j",)


def test_trapezoid_duration_by_hand() -> None:
    # 1 rad at v=1, a=2: 0.5 s ramps covering 0.25 rad each, 0.5 rad cruise in 0.5 s
    traj = time_parameterize(np.array([[0.0], [1.0]]), ONE, np.array([1.0]), np.array([2.0]))
    assert traj.duration == pytest.approx(1.5)
    assert np.max(traj.velocities) == pytest.approx(1.0)
    mid = int(np.argmin(np.abs(traj.times - 0.75)))
    assert traj.positions[mid, 0] == pytest.approx(0.25 + (traj.times[mid] - 0.5), abs=1e-9)


def test_triangle_duration_by_hand() -> None:
    # 0.1 rad never reaches 1 rad/s at a=2: two ramps of sqrt(0.1 / 2) s
    traj = time_parameterize(np.array([[0.0], [0.1]]), ONE, np.array([1.0]), np.array([2.0]))
    assert traj.duration == pytest.approx(2 * math.sqrt(0.05))
    assert np.max(traj.velocities) <= 2 * math.sqrt(0.05) + 1e-9


def test_slowest_joint_sets_the_pace_and_all_arrive_together() -> None:
    names = ("a", "b")
    traj = time_parameterize(
        np.array([[0.0, 0.0], [2.0, 0.5]]), names, np.array([1.0, 1.0]), np.array([10.0, 10.0])
    )
    # joint a needs >= 2 s at 1 rad/s; b moves proportionally
    assert traj.duration == pytest.approx(2.0 + 0.1)
    ratio = traj.positions[1:, 1] / traj.positions[1:, 0]
    np.testing.assert_allclose(ratio, 0.25)
    np.testing.assert_allclose(traj.end, [2.0, 0.5])
    np.testing.assert_allclose(traj.velocities[-1], 0.0)


waypoint_lists = st.lists(
    st.lists(st.floats(-2.0, 2.0, allow_nan=False), min_size=3, max_size=3),
    min_size=1,
    max_size=5,
)


@settings(max_examples=80, deadline=None)
@given(
    waypoint_lists,
    st.floats(0.2, 3.0),
    st.floats(0.5, 6.0),
    st.sampled_from([0.01, 0.05, 0.1]),
)
def test_limits_and_consistency(
    points: list[list[float]], vmax: float, amax: float, period: float
) -> None:
    names = ("a", "b", "c")
    waypoints = np.array(points)
    v = np.array([vmax, vmax * 0.5, vmax * 2])
    a = np.array([amax, amax * 2, amax * 0.5])
    traj = time_parameterize(waypoints, names, v, a, period)
    assert traj.times[0] == 0.0
    assert np.all(np.diff(traj.times) > 0)
    assert np.all(np.diff(traj.times) <= period + 1e-9)
    assert np.all(np.abs(traj.velocities) <= v * (1 + 1e-9))
    assert np.all(np.abs(traj.accelerations) <= a * (1 + 1e-9))
    np.testing.assert_allclose(traj.start, waypoints[0], atol=1e-12)
    np.testing.assert_allclose(traj.end, waypoints[-1], atol=1e-12)
    # every waypoint is visited
    for waypoint in waypoints:
        assert np.min(np.max(np.abs(traj.positions - waypoint), axis=1)) < 1e-9
    # finite differences of positions bounded by the velocity limits
    if len(traj) > 1:
        dt = np.diff(traj.times)[:, None]
        assert np.all(np.abs(np.diff(traj.positions, axis=0)) / dt <= v * (1 + 1e-6))


def test_bad_input() -> None:
    with pytest.raises(PlanningError, match=r"n x 1 array"):
        time_parameterize(np.zeros((2, 2)), ONE, np.ones(1), np.ones(1))
    with pytest.raises(PlanningError, match="sample period must be positive"):
        time_parameterize(np.zeros((2, 1)), ONE, np.ones(1), np.ones(1), 0.0)


def test_standing_still_is_one_point() -> None:
    traj = time_parameterize(np.zeros((3, 1)), ONE, np.ones(1), np.ones(1))
    assert len(traj) == 1
    assert traj.duration == 0.0
