"""Joint trajectories (as in trajectory_msgs/JointTrajectory) sampled by time_from_start.

Segments are interpolated like ros_control's joint_trajectory_controller: linear when the
points carry positions only, cubic Hermite when they also carry velocities.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from simbridge.errors import SimError

__all__ = ["Trajectory", "TrajectoryPoint"]

Vector = NDArray[np.float64]


@dataclass(frozen=True)
class TrajectoryPoint:
    """Positions (and optionally velocities) to reach `time` seconds after the start."""

    time: float
    positions: tuple[float, ...]
    velocities: tuple[float, ...] | None = None


@dataclass(frozen=True)
class Trajectory:
    """Waypoints for `joints`, strictly increasing in time."""

    joints: tuple[str, ...]
    points: tuple[TrajectoryPoint, ...]

    def __post_init__(self) -> None:
        if not self.joints or len(set(self.joints)) != len(self.joints):
            raise SimError(f"trajectory joint names must be non-empty and unique: {self.joints}")
        if not self.points:
            raise SimError("trajectory has no points")
        last = -math.inf
        for i, point in enumerate(self.points):
            if len(point.positions) != len(self.joints):
                raise SimError(
                    f"trajectory point {i}: {len(point.positions)} positions for "
                    f"{len(self.joints)} joints"
                )
            if point.velocities is not None and len(point.velocities) != len(self.joints):
                raise SimError(
                    f"trajectory point {i}: {len(point.velocities)} velocities for "
                    f"{len(self.joints)} joints"
                )
            values = [point.time, *point.positions, *(point.velocities or ())]
            if not all(math.isfinite(v) for v in values):
                raise SimError(f"trajectory point {i}: values must be finite")
            if point.time < 0 or point.time <= last:
                raise SimError(
                    f"trajectory point {i}: time_from_start {point.time} must be >= 0 and "
                    f"after the previous point's {last}"
                )
            last = point.time

    @property
    def duration(self) -> float:
        """time_from_start of the last point."""
        return self.points[-1].time

    def starting_from(self, current: Mapping[str, float]) -> Trajectory:
        """This trajectory with the current positions (at rest) as a point at t=0, when the
        first point lies in the future (as controllers do)."""
        if self.points[0].time == 0.0:
            return self
        try:
            start = tuple(float(current[j]) for j in self.joints)
        except KeyError as exc:
            raise SimError(f"trajectory joint {exc} has no current position") from None
        first = TrajectoryPoint(0.0, start, (0.0,) * len(self.joints))
        return Trajectory(self.joints, (first, *self.points))

    def sample(self, t: float) -> tuple[Vector, Vector]:
        """Positions and velocities at time `t` after the start (held at the ends)."""
        pts = self.points
        if len(pts) == 1 or t < pts[0].time or t > pts[-1].time:
            held = pts[0] if t < pts[0].time else pts[-1]
            return np.array(held.positions), np.zeros(len(self.joints))
        i = min(bisect.bisect_right([p.time for p in pts], t) - 1, len(pts) - 2)
        a, b = pts[i], pts[i + 1]
        h = b.time - a.time
        s = (t - a.time) / h
        p0, p1 = np.array(a.positions), np.array(b.positions)
        if a.velocities is None or b.velocities is None:
            return p0 + s * (p1 - p0), (p1 - p0) / h
        v0, v1 = np.array(a.velocities) * h, np.array(b.velocities) * h
        h00, h10, h01, h11 = (
            2 * s**3 - 3 * s**2 + 1,
            s**3 - 2 * s**2 + s,
            -2 * s**3 + 3 * s**2,
            s**3 - s**2,
        )
        d00, d10, d01, d11 = (
            6 * s**2 - 6 * s,
            3 * s**2 - 4 * s + 1,
            -6 * s**2 + 6 * s,
            3 * s**2 - 2 * s,
        )
        pos = h00 * p0 + h10 * v0 + h01 * p1 + h11 * v1
        vel = (d00 * p0 + d10 * v0 + d01 * p1 + d11 * v1) / h
        return pos, vel

    @staticmethod
    def from_lists(
        joints: Sequence[str],
        times: Sequence[float],
        positions: Sequence[Sequence[float]],
        velocities: Sequence[Sequence[float]] | None = None,
    ) -> Trajectory:
        """Build from parallel lists (handy for tests and the ROS message converter)."""
        points = tuple(
            TrajectoryPoint(
                float(t),
                tuple(float(v) for v in pos),
                tuple(float(v) for v in velocities[i]) if velocities else None,
            )
            for i, (t, pos) in enumerate(zip(times, positions, strict=True))
        )
        return Trajectory(tuple(joints), points)
