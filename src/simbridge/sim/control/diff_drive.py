"""Differential drive: body twist (v, w) to wheel speeds and back, with limits and a timeout.

Kinematics (REP 103 base frame, x forward, z up; wheels spin positively when rolling
forward): v = r (wl + wr) / 2 and w = r (wr - wl) / L for wheel radius r and wheel
separation L. The controller is pure: it is fed commands and the time, and returns
wheel velocity targets; `simbridge.sim.ros.cmd_vel_controller` connects it to /cmd_vel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from simbridge.errors import SimError

__all__ = [
    "DiffDriveConfig",
    "DiffDriveController",
    "DiffDriveKinematics",
    "DiffDriveLimits",
    "Pose2D",
]


def _require_positive(what: str, value: float) -> None:
    if not math.isfinite(value) or value <= 0:
        raise SimError(f"diff drive {what} must be a finite number > 0, got {value}")


@dataclass(frozen=True)
class Pose2D:
    """A planar pose: position (m) and heading (rad, counter-clockwise from +x)."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0


@dataclass(frozen=True)
class DiffDriveKinematics:
    """Wheel radius r and separation L (distance between the wheels' contact points), m."""

    wheel_radius: float
    wheel_separation: float

    def __post_init__(self) -> None:
        _require_positive("wheel_radius", self.wheel_radius)
        _require_positive("wheel_separation", self.wheel_separation)

    def wheel_velocities(self, linear: float, angular: float) -> tuple[float, float]:
        """(left, right) wheel speeds (rad/s) moving the base at `linear` m/s, `angular` rad/s."""
        half = angular * self.wheel_separation / 2
        return (linear - half) / self.wheel_radius, (linear + half) / self.wheel_radius

    def body_twist(self, left: float, right: float) -> tuple[float, float]:
        """(linear m/s, angular rad/s) of the base for wheel speeds `left`, `right` (rad/s)."""
        r = self.wheel_radius
        return r * (left + right) / 2, r * (right - left) / self.wheel_separation

    def integrate(self, pose: Pose2D, left_delta: float, right_delta: float) -> Pose2D:
        """Dead reckoning: `pose` after the wheels turned by `left_delta`, `right_delta` (rad),
        assuming constant curvature in between (exact for arcs and straight lines)."""
        distance, turn = self.body_twist(left_delta, right_delta)
        if abs(turn) < 1e-9:
            dx, dy = distance * math.cos(pose.yaw), distance * math.sin(pose.yaw)
        else:
            radius = distance / turn
            dx = radius * (math.sin(pose.yaw + turn) - math.sin(pose.yaw))
            dy = -radius * (math.cos(pose.yaw + turn) - math.cos(pose.yaw))
        yaw = math.remainder(pose.yaw + turn, math.tau)
        return Pose2D(pose.x + dx, pose.y + dy, yaw)


@dataclass(frozen=True)
class DiffDriveLimits:
    """Bounds on the base's commanded motion (m/s, rad/s, m/s^2, rad/s^2)."""

    max_linear_velocity: float = 1.0
    max_angular_velocity: float = 2.0
    max_linear_acceleration: float = 1.0
    max_angular_acceleration: float = 3.0

    def __post_init__(self) -> None:
        for name in (
            "max_linear_velocity",
            "max_angular_velocity",
            "max_linear_acceleration",
            "max_angular_acceleration",
        ):
            _require_positive(name, getattr(self, name))


@dataclass(frozen=True)
class DiffDriveConfig:
    """A diff drive on two wheel joints, commanded by geometry_msgs/Twist on `topic`.

    `wheel_radius` / `wheel_separation` None: measured from the model (the wheel's
    collision cylinder and the distance between the wheel joints).
    """

    left_joint: str
    right_joint: str
    topic: str = "/cmd_vel"
    wheel_radius: float | None = None
    wheel_separation: float | None = None
    limits: DiffDriveLimits = DiffDriveLimits()
    cmd_timeout: float = 0.5

    def __post_init__(self) -> None:
        if self.left_joint == self.right_joint:
            raise SimError(f"diff drive: left and right wheel are both {self.left_joint!r}")
        _require_positive("cmd_timeout", self.cmd_timeout)
        for name in ("wheel_radius", "wheel_separation"):
            value = getattr(self, name)
            if value is not None:
                _require_positive(name, value)


class DiffDriveController:
    """Turns (v, w) commands into wheel velocity targets.

    Commands are clamped to the velocity limits; the output then moves towards them no
    faster than the acceleration limits allow. Without a command for `cmd_timeout`
    seconds the target becomes zero and the base brakes (at the acceleration limits).
    """

    def __init__(
        self,
        kinematics: DiffDriveKinematics,
        limits: DiffDriveLimits | None = None,
        cmd_timeout: float = 0.5,
    ) -> None:
        _require_positive("cmd_timeout", cmd_timeout)
        self.kinematics = kinematics
        self.limits = limits or DiffDriveLimits()
        self.cmd_timeout = cmd_timeout
        self._target = (0.0, 0.0)
        self._output = (0.0, 0.0)
        self._commanded_at: float | None = None
        self._updated_at: float | None = None

    @property
    def twist(self) -> tuple[float, float]:
        """The (linear, angular) velocity the wheels were last set to produce."""
        return self._output

    def timed_out(self, now: float) -> bool:
        """Whether the latest command is older than `cmd_timeout` (or none came yet)."""
        return self._commanded_at is None or now - self._commanded_at > self.cmd_timeout

    def command(self, linear: float, angular: float, now: float) -> None:
        """A new cmd_vel at time `now` (s); raises SimError for non-finite values."""
        if not (math.isfinite(linear) and math.isfinite(angular)):
            raise SimError(f"cmd_vel must be finite, got linear {linear}, angular {angular}")
        lim = self.limits
        self._target = (
            min(max(linear, -lim.max_linear_velocity), lim.max_linear_velocity),
            min(max(angular, -lim.max_angular_velocity), lim.max_angular_velocity),
        )
        self._commanded_at = now

    def update(self, now: float) -> tuple[float, float]:
        """(left, right) wheel velocity targets (rad/s) at time `now`."""
        dt = 0.0 if self._updated_at is None else max(now - self._updated_at, 0.0)
        self._updated_at = now
        target = (0.0, 0.0) if self.timed_out(now) else self._target
        lim = self.limits
        steps = (lim.max_linear_acceleration * dt, lim.max_angular_acceleration * dt)
        self._output = (
            self._output[0] + min(max(target[0] - self._output[0], -steps[0]), steps[0]),
            self._output[1] + min(max(target[1] - self._output[1], -steps[1]), steps[1]),
        )
        return self.kinematics.wheel_velocities(*self._output)

    def reset(self) -> None:
        """Forget commands and motion (after a simulation reset)."""
        self._target = self._output = (0.0, 0.0)
        self._commanded_at = self._updated_at = None
