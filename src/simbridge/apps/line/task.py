"""The line's layout and one run's work: where parts start, where the pallet loads and
unloads, where parts must end up. World frame: the table top is z = 0."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simbridge.errors import AppError

__all__ = [
    "ARM_BASES",
    "CONVEYOR_X",
    "LOAD_Y",
    "PALLET_TOP",
    "PART_SIZE",
    "TRAVEL_M",
    "LineTask",
    "PartStart",
]

PART_SIZE = 0.05
"""Edge length (m) of the cubic parts."""
ARM_BASES = {"arm_in": (0.0, 0.30), "arm_out": (0.0, -0.30)}
"""Where each arm's base_link stands (x, y) on the table, unrotated."""
CONVEYOR_X = 0.24
"""The rail's x (m); the pallet slides along y."""
LOAD_Y = 0.15
"""Pallet centre y (m) at pallet_joint = 0, where arm_in loads it."""
TRAVEL_M = 0.30
"""How far the pallet travels (pallet_joint = -TRAVEL_M at the unload station)."""
PALLET_TOP = 0.022
"""Height (m) of the pallet's top face above the table."""

_IN_REACH = (0.18, 0.28)
"""Distances (m) from arm_in's base at which parts are drawn."""
_IN_BEARING = (math.radians(25.0), math.radians(95.0))
"""Bearings (rad) from arm_in's x axis at which parts are drawn (away from the conveyor)."""
_MIN_SEPARATION = 0.10
"""Smallest distance (m) between two parts' centres at the start."""
_OUT_RADIUS = 0.24
_OUT_BEARINGS = (-35.0, -62.0, -89.0, -116.0)
"""Output slots: bearings (deg) from arm_out's x axis at _OUT_RADIUS (m)."""
MAX_PARTS = len(_OUT_BEARINGS)


@dataclass(frozen=True)
class PartStart:
    """A part's start in the input area: centre x, y (m, world) and yaw (rad)."""

    x: float
    y: float
    yaw: float


@dataclass(frozen=True)
class LineTask:
    """The parts to move, in order; part k goes to output slot k."""

    parts: tuple[PartStart, ...]

    def __post_init__(self) -> None:
        if not 1 <= len(self.parts) <= MAX_PARTS:
            raise AppError(f"a line run moves 1 to {MAX_PARTS} parts, got {len(self.parts)}")

    @classmethod
    def random(cls, seed: int, parts: int = 3) -> LineTask:
        """``parts`` parts at seeded poses in the input area (same seed, same task)."""
        if not 1 <= parts <= MAX_PARTS:
            raise AppError(f"--parts must be 1 to {MAX_PARTS}, got {parts}")
        rng = np.random.default_rng(seed)
        base_x, base_y = ARM_BASES["arm_in"]
        drawn: list[PartStart] = []
        while len(drawn) < parts:
            radius = float(rng.uniform(*_IN_REACH))
            bearing = float(rng.uniform(*_IN_BEARING))
            x, y = base_x + radius * math.cos(bearing), base_y + radius * math.sin(bearing)
            if all(math.dist((x, y), (p.x, p.y)) >= _MIN_SEPARATION for p in drawn):
                yaw = float(rng.uniform(-math.pi / 4, math.pi / 4))
                drawn.append(PartStart(x, y, yaw))
        return cls(tuple(drawn))

    @classmethod
    def default(cls, parts: int = 3) -> LineTask:
        """The task of seed 0."""
        return cls.random(0, parts)

    def target(self, index: int) -> tuple[float, float, float]:
        """Where part ``index``'s centre must end up (output slot ``index``), world frame."""
        base_x, base_y = ARM_BASES["arm_out"]
        bearing = math.radians(_OUT_BEARINGS[index])
        return (
            base_x + _OUT_RADIUS * math.cos(bearing),
            base_y + _OUT_RADIUS * math.sin(bearing),
            PART_SIZE / 2,
        )

    @staticmethod
    def pallet_slot(pallet_q: float) -> tuple[float, float, float]:
        """Where a part's centre sits on the pallet when pallet_joint is ``pallet_q``."""
        return (CONVEYOR_X, LOAD_Y + pallet_q, PALLET_TOP + PART_SIZE / 2)
