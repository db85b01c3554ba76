"""What a line run measured: parts delivered, placement errors, timing, per-robot traffic."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

__all__ = ["DELIVERY_TOLERANCE_M", "LineResult"]

DELIVERY_TOLERANCE_M = 0.02
"""Largest distance (m) between a part's final centre and its output slot's for delivery."""


@dataclass(frozen=True)
class LineResult:
    """Outcome of one run, measured from the parts' final poses in the simulation.

    ``cycle_s`` is simulated seconds per delivered part (from the first goal to the last
    part set down); ``sim_s`` / ``wall_s`` cover the whole run, planning pauses included.
    """

    parts: int
    delivered: int
    placement_error_m: tuple[float, ...]
    cycle_s: float
    sim_s: float
    wall_s: float
    robots: dict[str, dict[str, Any]]
    cpu_s: float = 0.0
    """CPU seconds the process spent (all threads) while the world ran: on a busy machine
    ``sim_s / cpu_s`` says what the run would reach with a core to itself."""
    seed: int | None = None
    backend: str = "local"
    error: str | None = None
    planning_wall_s: float = 0.0
    final_positions: tuple[tuple[float, float, float], ...] = field(default=())
    video: str | None = None

    @property
    def success(self) -> bool:
        """Every part delivered within DELIVERY_TOLERANCE_M and no step failed."""
        return self.error is None and self.delivered == self.parts

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall second over the run."""
        return self.sim_s / self.wall_s if self.wall_s > 0 else 0.0

    def to_dict(self) -> dict[str, Any]:
        """The `--json` line: the keys every demo has (success, seed, backend, sim_s, wall_s,
        realtime_factor, error), then parts, delivered, placement_error_m, cycle_s, robots
        and the extras."""
        return {
            "success": self.success,
            "seed": self.seed,
            "backend": self.backend,
            "sim_s": round(self.sim_s, 3),
            "wall_s": round(self.wall_s, 3),
            "realtime_factor": round(self.realtime_factor, 2),
            "error": self.error,
            "parts": self.parts,
            "delivered": self.delivered,
            "placement_error_m": [round(e, 5) for e in self.placement_error_m],
            "cycle_s": round(self.cycle_s, 3),
            "robots": self.robots,
            "cpu_s": round(self.cpu_s, 3),
            "planning_wall_s": round(self.planning_wall_s, 3),
            "video": self.video,
        }
