"""Repeated benchmark runs: the best and the median of each figure, and the load they
ran under (the machine may be shared, so a single run says little)."""

from __future__ import annotations

import os
import statistics
from collections.abc import Sequence

__all__ = ["REPEATS", "best_and_median", "load_average"]

REPEATS = max(int(os.environ.get("SIMBRIDGE_BENCH_REPEATS", "3")), 1)
"""Runs per figure (at least 3 for the README table; fewer for a quick look)."""


def load_average() -> float:
    """The 1-minute load average now (compare it with the machine's core count)."""
    return os.getloadavg()[0]


def best_and_median(values: Sequence[float], lower_is_better: bool = False) -> tuple[float, float]:
    """(best, median) of the runs' values: the best is the highest, or the lowest for
    figures such as latencies."""
    if not values:
        raise ValueError("no runs to summarize")
    best = min(values) if lower_is_better else max(values)
    return best, statistics.median(values)
