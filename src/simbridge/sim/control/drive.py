"""Joint drives in the spirit of Unity's ArticulationDrive: position, velocity or effort control."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import Enum
from typing import Any

from simbridge.errors import SimError

__all__ = ["DriveMode", "DriveSpec"]


class DriveMode(Enum):
    """What the drive's target means."""

    POSITION = "position"
    VELOCITY = "velocity"
    EFFORT = "effort"
    NONE = "none"

    @staticmethod
    def parse(text: str) -> DriveMode:
        """The mode named `text`; raises `SimError` listing the valid names."""
        try:
            return DriveMode(text)
        except ValueError:
            valid = ", ".join(m.value for m in DriveMode)
            raise SimError(f"unknown drive mode '{text}' (valid: {valid})") from None


@dataclass(frozen=True)
class DriveSpec:
    """Force = stiffness * (target - q) + damping * (target_velocity - qdot), clipped to the limit.

    In VELOCITY mode stiffness is ignored; in EFFORT mode the target is the force itself;
    NONE leaves the joint passive. `force_limit=None` means "as the scene's effort-limit
    policy says" (by default the URDF effort limit if it has one), `math.inf` unlimited.
    The defaults (Unity's importer's) hold an arm still under gravity, and stay stable
    because MuJoCo's implicit integrator treats the damping term implicitly (stable while
    timestep * stiffness / damping < 2).
    """

    mode: DriveMode = DriveMode.POSITION
    stiffness: float = 10000.0
    damping: float = 100.0
    force_limit: float | None = None

    def __post_init__(self) -> None:
        for name in ("stiffness", "damping"):
            value = getattr(self, name)
            if not math.isfinite(value) or value < 0:
                raise SimError(f"drive {name} must be finite and >= 0, got {value}")
        if self.force_limit is not None and not self.force_limit > 0:
            raise SimError(f"drive force_limit must be > 0 (or null), got {self.force_limit}")

    def gains(self) -> tuple[float, float]:
        """Effective (stiffness, damping) the mode uses."""
        if self.mode is DriveMode.POSITION:
            return self.stiffness, self.damping
        if self.mode is DriveMode.VELOCITY:
            return 0.0, self.damping
        return 0.0, 0.0

    def with_changes(self, **changes: Any) -> DriveSpec:
        """A copy with some fields replaced (validated again)."""
        return replace(self, **changes)
