"""Pick and place over 20 seeds on the local backend: success rate, time per run and per phase.

Run: `python -m benchmarks.bench_pick_and_place [--markdown]` (prints a table);
`run()` returns the rows: one per seed, then a summary row (success rate, means).
"""

from __future__ import annotations

import statistics
import time
from typing import Any

from simbridge.apps.pick_and_place import PickAndPlaceResult, run_pick_and_place

__all__ = ["PHASES", "SEEDS", "run"]

SEEDS = tuple(range(20))
PHASES = (
    "plan",
    "pre_grasp",
    "grasp",
    "close_gripper",
    "pick_up",
    "place",
    "open_gripper",
    "release",
)


def _row(seed: int, result: PickAndPlaceResult, wall: float) -> dict[str, Any]:
    walls = {p.name: p.wall_s for p in result.phases}
    row: dict[str, Any] = {
        "seed": seed,
        "success": "yes" if result.success else "no",
        "cube_error_cm": round(result.cube_error_m * 100, 2),
        "sim_s": round(result.sim_time, 2),
        "run_wall_s": round(wall, 3),
    }
    row.update({f"{name}_s": round(walls.get(name, 0.0), 3) for name in PHASES})
    row["error"] = (result.error or "")[:60]
    return row


def run(seeds: tuple[int, ...] = SEEDS) -> list[dict[str, Any]]:
    """One row per seed (local backend, headless), then a summary row of rates and means."""
    rows = []
    for seed in seeds:
        began = time.perf_counter()
        result = run_pick_and_place("local", seed=seed, progress=None)
        rows.append(_row(seed, result, time.perf_counter() - began))
    summary: dict[str, Any] = {
        "seed": "mean",
        "success": f"{sum(r['success'] == 'yes' for r in rows)}/{len(rows)}",
        "cube_error_cm": round(statistics.mean(r["cube_error_cm"] for r in rows), 2),
        "sim_s": round(statistics.mean(r["sim_s"] for r in rows), 2),
        "run_wall_s": round(statistics.mean(r["run_wall_s"] for r in rows), 3),
    }
    summary.update({f"{n}_s": round(statistics.mean(r[f"{n}_s"] for r in rows), 3) for n in PHASES})
    summary["error"] = ""
    return [*rows, summary]


if __name__ == "__main__":
    import sys

    from benchmarks.table import format_table

    print(format_table(run(), markdown="--markdown" in sys.argv))
