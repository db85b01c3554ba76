"""Time parameterisation: synchronised trapezoidal profiles per path segment, within limits."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from simbridge.errors import PlanningError
from simbridge.planning.geometry import FloatArray

__all__ = ["JointTrajectory", "time_parameterize"]


@dataclass(frozen=True)
class JointTrajectory:
    """Timed joint points: ``times`` (n,); positions, velocities, accelerations (n, dof)."""

    joint_names: tuple[str, ...]
    times: FloatArray
    positions: FloatArray
    velocities: FloatArray
    accelerations: FloatArray

    @property
    def duration(self) -> float:
        """Time from start of the last point (s)."""
        return float(self.times[-1])

    @property
    def start(self) -> FloatArray:
        """First joint configuration."""
        return np.asarray(self.positions[0])

    @property
    def end(self) -> FloatArray:
        """Last joint configuration."""
        return np.asarray(self.positions[-1])

    def __len__(self) -> int:
        return int(self.times.shape[0])


@dataclass(frozen=True)
class _Segment:
    """Path parameter s in [0, 1] along start + s * delta with a trapezoidal s(t)."""

    start: FloatArray
    delta: FloatArray
    accel: float  # ds/dt^2
    peak: float  # ds/dt at cruise
    ramp: float  # seconds accelerating (and decelerating)
    duration: float

    @classmethod
    def fit(
        cls, start: FloatArray, end: FloatArray, vmax: FloatArray, amax: FloatArray
    ) -> _Segment:
        delta = end - start
        moving = np.abs(delta) > 1e-12
        speed = float(np.min(vmax[moving] / np.abs(delta[moving])))
        accel = float(np.min(amax[moving] / np.abs(delta[moving])))
        if speed * speed / accel >= 1.0:  # triangular: never reaches cruise speed
            ramp = math.sqrt(1.0 / accel)
            return cls(start, delta, accel, accel * ramp, ramp, 2.0 * ramp)
        ramp = speed / accel
        return cls(start, delta, accel, speed, ramp, 2.0 * ramp + (1.0 - speed * ramp) / speed)

    def sample(self, t: float) -> tuple[float, float, float]:
        """(s, ds/dt, d2s/dt2) at time t into the segment."""
        a, v, ramp, total = self.accel, self.peak, self.ramp, self.duration
        if t <= ramp:
            return 0.5 * a * t * t, a * t, a
        if t < total - ramp:
            return 0.5 * a * ramp * ramp + v * (t - ramp), v, 0.0
        left = max(total - t, 0.0)
        return 1.0 - 0.5 * a * left * left, a * left, -a if left > 0 else 0.0


def time_parameterize(
    waypoints: FloatArray,
    joint_names: tuple[str, ...],
    velocity_limits: FloatArray,
    acceleration_limits: FloatArray,
    sample_period: float = 0.05,
) -> JointTrajectory:
    """Timed trajectory through ``waypoints`` (n x dof), stopping at each one.

    Every segment is a straight joint-space line timed by one trapezoidal profile shared by all
    joints, so each joint stays within its velocity and acceleration limit and all arrive
    together. Points are sampled every ``sample_period`` seconds plus each segment's end.
    """
    points = np.asarray(waypoints, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != len(joint_names) or len(points) == 0:
        raise PlanningError(
            f"waypoints must be an n x {len(joint_names)} array, got shape {points.shape}"
        )
    if sample_period <= 0:
        raise PlanningError(f"sample period must be positive, got {sample_period}")
    vmax = np.asarray(velocity_limits, dtype=np.float64)
    amax = np.asarray(acceleration_limits, dtype=np.float64)
    times, pos, vel, acc = (
        [0.0],
        [points[0]],
        [np.zeros_like(points[0])],
        [np.zeros_like(points[0])],
    )
    elapsed = 0.0
    for a, b in itertools.pairwise(points):
        if np.all(np.abs(b - a) <= 1e-12):  # negligible move: stand still
            continue
        segment = _Segment.fit(a, b, vmax, amax)
        steps = max(1, math.ceil(segment.duration / sample_period - 1e-9))
        for k in range(1, steps + 1):
            t = segment.duration * k / steps
            s, ds, dds = segment.sample(t)
            times.append(elapsed + t)
            pos.append(segment.start + s * segment.delta)
            vel.append(ds * segment.delta)
            acc.append(dds * segment.delta)
        pos[-1] = b.copy()
        vel[-1] = np.zeros_like(b)
        acc[-1] = np.zeros_like(b)
        elapsed += segment.duration
    return JointTrajectory(
        joint_names=joint_names,
        times=np.array(times),
        positions=np.vstack(pos),
        velocities=np.vstack(vel),
        accelerations=np.vstack(acc),
    )
