"""What a pick-and-place run measured: success, cube error, per-phase timings, cube track."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simbridge.planning import FloatArray

__all__ = ["SUCCESS_TOLERANCE_M", "UPRIGHT_TOLERANCE_DEG", "PhaseTiming", "PickAndPlaceResult"]

SUCCESS_TOLERANCE_M = 0.02
"""Largest distance (m) between the cube's final centre and the target's for success."""
UPRIGHT_TOLERANCE_DEG = 10.0
"""Largest tilt (deg) of the cube's nearest-to-vertical axis for it to count as upright."""


@dataclass(frozen=True)
class PhaseTiming:
    """One phase: simulated seconds it covered and wall-clock seconds it took."""

    name: str
    sim_s: float
    wall_s: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"name": self.name, "sim_s": round(self.sim_s, 4), "wall_s": round(self.wall_s, 4)}


@dataclass(frozen=True)
class PickAndPlaceResult:
    """Outcome of one run; success is measured from the cube's final pose, not assumed.

    ``cube_track`` holds (sim time, x, y, z) of the cube's centre after every physics step;
    ``gripper_closed_at`` is the sim time the gripper started closing on the cube.
    """

    success: bool
    cube_error_m: float
    tilt_deg: float
    phases: tuple[PhaseTiming, ...]
    backend: str
    seed: int | None
    cube_start: tuple[float, float, float]
    target: tuple[float, float, float]
    cube_final: tuple[float, float, float]
    error: str | None = None
    gripper_closed_at: float | None = None
    trajectories: int = 0
    cube_track: FloatArray = field(default_factory=lambda: np.zeros((0, 4)), repr=False)
    video: str | None = None

    @property
    def upright(self) -> bool:
        """Whether the cube stands on a face (tilt within UPRIGHT_TOLERANCE_DEG)."""
        return self.tilt_deg <= UPRIGHT_TOLERANCE_DEG

    @property
    def sim_time(self) -> float:
        """Simulated seconds over all phases."""
        return sum(p.sim_s for p in self.phases)

    @property
    def wall_time(self) -> float:
        """Wall-clock seconds over all phases."""
        return sum(p.wall_s for p in self.phases)

    def to_dict(self) -> dict[str, Any]:
        """The JSON summary: the keys every demo has (success, seed, backend, sim_s, wall_s,
        realtime_factor, error), then cube_error_m, phases and the details. `seed` None is
        the fixed default task (not drawn from a seed)."""
        wall = self.wall_time
        return {
            "success": self.success,
            "seed": self.seed,
            "backend": self.backend,
            "sim_s": round(self.sim_time, 4),
            "wall_s": round(wall, 4),
            "realtime_factor": round(self.sim_time / wall, 3) if wall > 0 else 0.0,
            "error": self.error,
            "cube_error_m": round(self.cube_error_m, 5),
            "phases": [p.to_dict() for p in self.phases],
            "upright": self.upright,
            "tilt_deg": round(self.tilt_deg, 3),
            "cube_start": [round(v, 4) for v in self.cube_start],
            "target": [round(v, 4) for v in self.target],
            "cube_final": [round(v, 4) for v in self.cube_final],
            "trajectories": self.trajectories,
            "video": self.video,
        }
