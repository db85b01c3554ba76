"""Trajectory interpolation (pure math) and following it with the drives."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from simbridge.errors import SimError
from simbridge.sim.control import Trajectory, TrajectoryPoint
from tests.sim.worlds import arm_world


def test_linear_segments_without_velocities() -> None:
    traj = Trajectory.from_lists(["a", "b"], [1.0, 3.0], [[0.0, 1.0], [2.0, -1.0]])
    pos, vel = traj.sample(2.0)
    np.testing.assert_allclose(pos, [1.0, 0.0])
    np.testing.assert_allclose(vel, [1.0, -1.0])
    np.testing.assert_allclose(traj.sample(0.5)[0], [0.0, 1.0])  # before the first point: held
    np.testing.assert_allclose(traj.sample(9.0)[0], [2.0, -1.0])  # after the last: held
    assert traj.duration == 3.0


def test_cubic_segment_hits_ends_with_given_velocities() -> None:
    traj = Trajectory.from_lists(["a"], [0.0, 2.0], [[0.0], [1.0]], [[0.0], [0.0]])
    # smoothstep: p(s) = 3s^2 - 2s^3 over s = t/2; at t=1: 0.5, velocity 1.5/2 * ... = 0.75
    pos, vel = traj.sample(1.0)
    assert pos[0] == pytest.approx(0.5)
    assert vel[0] == pytest.approx(0.75)
    pos, vel = traj.sample(0.5)
    s = 0.25
    assert pos[0] == pytest.approx(3 * s**2 - 2 * s**3)
    assert vel[0] == pytest.approx((6 * s - 6 * s**2) / 2)


@settings(max_examples=50, deadline=None)
@given(
    ends=st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(-3, 3), st.floats(-3, 3)),
    h=st.floats(0.1, 5),
    s=st.floats(0, 1),
)
def test_hermite_velocity_is_the_derivative_of_position(ends, h, s) -> None:
    p0, p1, v0, v1 = ends
    traj = Trajectory(
        (("j",)), (TrajectoryPoint(1.0, (p0,), (v0,)), TrajectoryPoint(1.0 + h, (p1,), (v1,)))
    )
    t = 1.0 + s * h
    eps = 1e-8 * h  # small: a one-sided difference at an end errs by eps * p'' / 2
    lo, hi = max(t - eps, 1.0), min(t + eps, 1.0 + h)
    if hi - lo < eps:
        return
    numeric = (traj.sample(hi)[0][0] - traj.sample(lo)[0][0]) / (hi - lo)
    assert traj.sample(t)[1][0] == pytest.approx(numeric, abs=1e-4 * (1 + abs(numeric)))
    np.testing.assert_allclose(traj.sample(1.0)[0], [p0])
    np.testing.assert_allclose(traj.sample(1.0 + h)[0], [p1], atol=1e-12)


def _hermite_reference(traj: Trajectory, t: float) -> tuple[list[float], list[float]]:
    """The textbook per-segment evaluation (Hermite basis in s = (t - t_a) / h, linear
    without velocities) that the cached polynomial table must reproduce."""
    pts = traj.points
    i = max(k for k in range(len(pts) - 1) if pts[k].time <= t)
    a, b = pts[i], pts[i + 1]
    h = b.time - a.time
    s = (t - a.time) / h
    pos, vel = [], []
    for j in range(len(traj.joints)):
        p0, p1 = a.positions[j], b.positions[j]
        if a.velocities is None or b.velocities is None:
            pos.append(p0 + s * (p1 - p0))
            vel.append((p1 - p0) / h)
            continue
        m0, m1 = a.velocities[j] * h, b.velocities[j] * h
        pos.append(
            (2 * s**3 - 3 * s**2 + 1) * p0
            + (s**3 - 2 * s**2 + s) * m0
            + (-2 * s**3 + 3 * s**2) * p1
            + (s**3 - s**2) * m1
        )
        vel.append(
            ((6 * s**2 - 6 * s) * p0 + (3 * s**2 - 4 * s + 1) * m0) / h
            + ((-6 * s**2 + 6 * s) * p1 + (3 * s**2 - 2 * s) * m1) / h
        )
    return pos, vel


@settings(max_examples=60, deadline=None)
@given(
    steps=st.lists(st.floats(0.05, 3), min_size=1, max_size=6),
    seed=st.integers(0, 2**32 - 1),
    cubic=st.booleans(),
    fractions=st.lists(st.floats(0, 1), min_size=1, max_size=20),
)
def test_sampling_matches_the_segment_formulas_anywhere(steps, seed, cubic, fractions) -> None:
    """Any time, in any segment, in any order (the table keeps no per-call state)."""
    rng = np.random.default_rng(seed)
    times = np.concatenate(([0.5], 0.5 + np.cumsum(steps)))
    positions = rng.uniform(-2, 2, (len(times), 3)).tolist()
    velocities = rng.uniform(-2, 2, (len(times), 3)).tolist() if cubic else None
    traj = Trajectory.from_lists(["a", "b", "c"], times.tolist(), positions, velocities)
    for fraction in fractions:
        t = float(times[0] + fraction * (times[-1] - times[0]))
        pos, vel = traj.sample(t)
        want_pos, want_vel = _hermite_reference(traj, t)
        np.testing.assert_allclose(pos, want_pos, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(vel, want_vel, rtol=1e-9, atol=1e-8)
    held, rest = traj.sample(times[-1] + 1.0)
    np.testing.assert_array_equal(held, positions[-1])
    np.testing.assert_array_equal(rest, [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(traj.sample(0.0)[0], positions[0])


def test_set_targets_equals_set_position_per_joint(tmp_path: Path) -> None:
    """The follower's vectorized write gives the targets, clamping and ctrl that one
    set_position per joint gives."""
    (tmp_path / "one").mkdir()
    (tmp_path / "many").mkdir()
    one, many = arm_world(tmp_path / "one"), arm_world(tmp_path / "many")
    joints = ["shoulder", "elbow"]
    for world in (one, many):
        world.drives.set_spec("elbow", world.drives.spec("elbow").with_changes(damping=37.0))
    positions, velocities = np.array([0.3, 99.0]), np.array([-0.4, 1.5])  # 99: past the limit
    for joint, q, v in zip(joints, positions, velocities, strict=True):
        one.drives.set_position(joint, float(q), float(v))
    many.drives.set_targets(many.drives.actuators(joints), positions, velocities)
    for joint in joints:
        assert many.drives.target(joint) == one.drives.target(joint)
    assert many.drives.target("elbow").position < 99.0  # clamped
    np.testing.assert_array_equal(many.data.ctrl, one.data.ctrl)


@pytest.mark.parametrize(
    ("joints", "times", "positions", "message"),
    [
        (["a"], [1.0, 1.0], [[0.0], [1.0]], "after the previous point"),
        (["a"], [-1.0], [[0.0]], "must be >= 0"),
        (["a", "a"], [1.0], [[0.0, 1.0]], "unique"),
        (["a"], [1.0], [[0.0, 1.0]], "2 positions for 1 joints"),
        (["a"], [1.0], [[float("nan")]], "finite"),
        (["a"], [], [], "no points"),
    ],
)
def test_invalid_trajectories(joints, times, positions, message) -> None:
    with pytest.raises(SimError, match=message):
        Trajectory.from_lists(joints, times, positions)


def test_world_follows_a_trajectory(tmp_path: Path) -> None:
    world = arm_world(tmp_path)
    traj = Trajectory.from_lists(
        ["shoulder", "elbow"], [1.0, 2.0], [[-0.5, 0.5], [-1.0, 1.2]], [[-0.5, 0.7], [0.0, 0.0]]
    )
    world.follower.start(traj, world.time)
    errors = []
    while world.follower.active is not None:
        world.step()
        want, _ = (
            world.follower.active.sample(world.time) if world.follower.active else (None, None)
        )
        if want is not None:
            got = world.joint_positions(["shoulder", "elbow"])
            errors.append(max(abs(got["shoulder"] - want[0]), abs(got["elbow"] - want[1])))
    assert world.time == pytest.approx(2.0, abs=0.003)
    assert max(errors) < 0.02  # tracks while moving
    world.step(500)
    final = world.joint_positions()
    assert final["shoulder"] == pytest.approx(-1.0, abs=2e-3)
    assert final["elbow"] == pytest.approx(1.2, abs=2e-3)


def test_following_an_undriven_joint_fails(tmp_path: Path) -> None:
    world = arm_world(tmp_path)
    with pytest.raises(SimError, match="grip_b"):
        world.follower.start(Trajectory.from_lists(["grip_b"], [1.0], [[0.0]]), 0.0)


def test_follower_ends_at_rest_when_the_clock_hits_the_end_exactly(tmp_path: Path) -> None:
    """With an exact sim clock the last update lands on the end time itself; the drives
    must then hold the last point at zero velocity, not the last segment's velocity."""
    world = arm_world(tmp_path)
    trajectory = Trajectory(
        ("elbow",), (TrajectoryPoint(0.0, (0.0,)), TrajectoryPoint(0.5, (0.9,)))
    )
    world.follower.start(trajectory, 1.0)
    assert world.follower.update(1.25)
    assert world.drives.target("elbow").velocity == pytest.approx(1.8)
    assert not world.follower.update(1.5)
    assert world.drives.target("elbow").position == pytest.approx(0.9)
    assert world.drives.target("elbow").velocity == 0.0
