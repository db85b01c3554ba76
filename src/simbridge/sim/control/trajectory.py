"""Joint trajectories (as in trajectory_msgs/JointTrajectory) sampled by time_from_start.

Segments are interpolated like ros_control's joint_trajectory_controller: linear when the
points carry positions only, cubic Hermite when they also carry velocities.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property

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

    @cached_property
    def _table(self) -> _SampleTable:
        """Point times and per-segment polynomial coefficients, built on the first sample."""
        return _SampleTable.of(self.points, len(self.joints))

    def sample(self, t: float) -> tuple[Vector, Vector]:
        """Positions and velocities at time `t` after the start (held at the ends)."""
        return self._table.sample(t)

    def aim(self, t: float) -> tuple[Vector, Vector]:
        """What a follower aims at, `t` after the start: the sample, and from the end on
        the last point at rest (sampling exactly at the end would give the last segment's
        velocity, and the drives would keep chasing it)."""
        return self._table.sample(math.inf if t >= self.duration else t)

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


class _SampleTable:
    """A trajectory's segments as cubics in the time since the segment's start, so a sample
    is one bisect over cached times and one small matrix product (no per-step rebuilding).

    Row block `[:n]` of a segment's matrix gives positions, `[n:]` velocities, from the
    powers (1, tau, tau^2, tau^3); linear segments have zero cubic terms."""

    def __init__(
        self, times: list[float], held: tuple[Vector, Vector], coefficients: NDArray[np.float64]
    ) -> None:
        self.times, self.coefficients = times, coefficients
        self.first, self.last = held
        self.zeros = np.zeros(len(self.first))
        self.end = len(times) - 2  # last segment index

    @staticmethod
    def of(points: tuple[TrajectoryPoint, ...], joints: int) -> _SampleTable:
        """The table of `points` (already validated) over `joints` joints."""
        times = [p.time for p in points]
        coefficients = np.zeros((max(len(points) - 1, 0), 2 * joints, 4))
        for i, (a, b) in enumerate(itertools.pairwise(points)):
            h = b.time - a.time
            p0, p1 = np.array(a.positions), np.array(b.positions)
            if a.velocities is None or b.velocities is None:
                c0, c1, c2, c3 = p0, (p1 - p0) / h, 0.0, 0.0
            else:  # cubic Hermite with end velocities v0, v1
                v0, v1 = np.array(a.velocities), np.array(b.velocities)
                c0, c1 = p0, v0
                c2 = (3 * (p1 - p0) / h - 2 * v0 - v1) / h
                c3 = (2 * (p0 - p1) / h + v0 + v1) / (h * h)
            block = coefficients[i]
            block[:joints, 0], block[:joints, 1] = c0, c1
            block[:joints, 2], block[:joints, 3] = c2, c3
            block[joints:, 0], block[joints:, 1], block[joints:, 2] = c1, 2 * c2, 3 * c3
        held = (np.array(points[0].positions), np.array(points[-1].positions))
        return _SampleTable(times, held, coefficients)

    def sample(self, t: float) -> tuple[Vector, Vector]:
        """Positions and velocities at `t` (new arrays; the end points held at rest)."""
        times = self.times
        if self.end < 0 or t < times[0] or t > times[-1]:
            held = self.first if t < times[0] else self.last
            return held.copy(), self.zeros.copy()
        i = min(bisect.bisect_right(times, t) - 1, self.end)
        tau = t - times[i]
        values = self.coefficients[i] @ np.array((1.0, tau, tau * tau, tau * tau * tau))
        n = len(self.first)
        return values[:n], values[n:]
