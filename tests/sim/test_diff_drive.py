"""Differential-drive kinematics, dead reckoning, limits and the command timeout."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from simbridge.errors import SimError
from simbridge.sim.control.diff_drive import (
    DiffDriveConfig,
    DiffDriveController,
    DiffDriveKinematics,
    DiffDriveLimits,
    Pose2D,
)

KIN = DiffDriveKinematics(wheel_radius=0.05, wheel_separation=0.23)
speeds = st.floats(-20.0, 20.0, allow_nan=False)


def test_wheel_speeds_golden_values() -> None:
    # straight at 0.5 m/s: both wheels 0.5 / 0.05 = 10 rad/s
    assert KIN.wheel_velocities(0.5, 0.0) == pytest.approx((10.0, 10.0))
    # turning in place at 1 rad/s: each wheel travels 0.115 m/s, i.e. 2.3 rad/s, opposite
    assert KIN.wheel_velocities(0.0, 1.0) == pytest.approx((-2.3, 2.3))
    # v = r (wl + wr) / 2, w = r (wr - wl) / L
    assert KIN.body_twist(4.0, 6.0) == pytest.approx((0.25, 0.05 * 2.0 / 0.23))


@given(speeds, speeds)
def test_twist_and_wheel_speeds_are_inverse(left: float, right: float) -> None:
    linear, angular = KIN.body_twist(left, right)
    assert KIN.wheel_velocities(linear, angular) == pytest.approx((left, right), abs=1e-9)


def test_dead_reckoning_straight_turn_and_quarter_circle() -> None:
    start = Pose2D()
    straight = KIN.integrate(start, 10.0, 10.0)  # 10 rad * 0.05 m = 0.5 m
    assert (straight.x, straight.y, straight.yaw) == pytest.approx((0.5, 0.0, 0.0))
    # in place: yaw = r (dr - dl) / L
    spin = KIN.integrate(start, -1.0, 1.0)
    assert (spin.x, spin.y, spin.yaw) == pytest.approx((0.0, 0.0, 0.1 / 0.23))
    # a quarter circle of radius R about (0, R): wheels travel (R -+ L/2) * pi/2
    radius = 1.0
    left = (radius - 0.115) * math.pi / 2 / 0.05
    right = (radius + 0.115) * math.pi / 2 / 0.05
    arc = KIN.integrate(start, left, right)
    assert (arc.x, arc.y, arc.yaw) == pytest.approx((1.0, 1.0, math.pi / 2))
    # split into many pieces it ends in the same place
    pose = start
    for _ in range(100):
        pose = KIN.integrate(pose, left / 100, right / 100)
    assert (pose.x, pose.y, pose.yaw) == pytest.approx((1.0, 1.0, math.pi / 2))


def test_velocity_limits_clamp_commands() -> None:
    fast = {"max_linear_acceleration": 100.0, "max_angular_acceleration": 100.0}
    limits = DiffDriveLimits(max_linear_velocity=0.4, max_angular_velocity=1.0, **fast)
    ctrl = DiffDriveController(KIN, limits)
    ctrl.update(0.0)
    ctrl.command(2.0, -5.0, 0.0)
    ctrl.update(0.2)
    assert ctrl.twist == pytest.approx((0.4, -1.0))


def test_acceleration_limit_ramps_the_output() -> None:
    ctrl = DiffDriveController(KIN, DiffDriveLimits(max_linear_acceleration=0.5))
    ctrl.update(0.0)
    ctrl.command(1.0, 0.0, 0.0)
    outputs = []
    for i in range(1, 6):
        ctrl.command(1.0, 0.0, i * 0.1)
        outputs.append(ctrl.update(i * 0.1))
    # 0.5 m/s^2 for 0.5 s reaches 0.25 m/s, i.e. 5 rad/s on both wheels
    assert [round(o[0], 9) for o in outputs] == pytest.approx([1.0, 2.0, 3.0, 4.0, 5.0])
    assert ctrl.twist == pytest.approx((0.25, 0.0))


def test_command_timeout_stops_the_base() -> None:
    ctrl = DiffDriveController(KIN, DiffDriveLimits(max_linear_acceleration=1000.0), 0.5)
    assert ctrl.timed_out(0.0)  # no command yet
    ctrl.update(0.0)
    ctrl.command(0.3, 0.0, 0.0)
    assert ctrl.update(0.4) == pytest.approx((6.0, 6.0))
    assert ctrl.update(0.5) == pytest.approx((6.0, 6.0))  # exactly the timeout: still on
    assert ctrl.timed_out(0.51)
    assert ctrl.update(0.51) == pytest.approx((0.0, 0.0))
    ctrl.command(0.1, 0.0, 0.6)  # a fresh command revives it
    assert ctrl.update(0.6) == pytest.approx((2.0, 2.0))
    ctrl.reset()
    assert ctrl.twist == (0.0, 0.0)
    assert ctrl.timed_out(0.6)


def test_bad_values_are_rejected_with_names() -> None:
    with pytest.raises(SimError, match="wheel_radius"):
        DiffDriveKinematics(0.0, 0.2)
    with pytest.raises(SimError, match="max_angular_acceleration"):
        DiffDriveLimits(max_angular_acceleration=-1.0)
    with pytest.raises(SimError, match="both 'w'"):
        DiffDriveConfig("w", "w")
    with pytest.raises(SimError, match="finite"):
        DiffDriveController(KIN).command(math.nan, 0.0, 0.0)
