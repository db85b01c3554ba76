"""The line demo's delivery table, shared by every backend's suite: one row per seed from
the demo's JSON summary (`LineResult.to_dict()`), then a summary row, so the tables of the
local and the ROS 2 runs have the same columns and compare row by row."""

from __future__ import annotations

import statistics
from typing import Any

__all__ = ["PARTS", "SEEDS", "delivery_row", "summary_row"]

SEEDS = tuple(range(20))
PARTS = 3


def delivery_row(seed: int, summary: dict[str, Any]) -> dict[str, Any]:
    """One seed's row: delivered within 2 cm, worst error, simulated seconds per part, the
    run's sim and wall seconds and its real-time factor (per wall and per CPU second)."""
    errors = summary.get("placement_error_m") or [0.0]
    sim_s, cpu_s = float(summary["sim_s"]), float(summary.get("cpu_s") or 0.0)
    return {
        "seed": seed,
        "delivered": f"{summary['delivered']}/{summary['parts']}",
        "worst_error_cm": round(max(errors) * 100, 2),
        "cycle_s": round(float(summary["cycle_s"]), 2),
        "sim_s": round(sim_s, 1),
        "wall_s": round(float(summary["wall_s"]), 1),
        "rtf": round(float(summary["realtime_factor"]), 1),
        "rtf_cpu": round(sim_s / cpu_s, 1) if cpu_s else 0.0,
        "error": (summary.get("error") or "")[:60],
    }


def summary_row(rows: list[dict[str, Any]], parts: int) -> dict[str, Any]:
    """Parts delivered over every seed (and the share), the worst error, mean cycle, sim and
    wall seconds, median real-time factors."""
    delivered = sum(int(r["delivered"].split("/")[0]) for r in rows)
    total = parts * len(rows)
    return {
        "seed": "all",
        "delivered": f"{delivered}/{total} ({100 * delivered / total:.0f}%)",
        "worst_error_cm": max(r["worst_error_cm"] for r in rows),
        "cycle_s": round(statistics.mean(r["cycle_s"] for r in rows), 2),
        "sim_s": round(statistics.mean(r["sim_s"] for r in rows), 1),
        "wall_s": round(statistics.mean(r["wall_s"] for r in rows), 1),
        "rtf": round(statistics.median(r["rtf"] for r in rows), 1),
        "rtf_cpu": round(statistics.median(r["rtf_cpu"] for r in rows), 1),
        "error": "rtf: median",
    }
