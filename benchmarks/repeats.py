"""Repeated benchmark runs: the best and the median of each figure, and the load they
ran under (the machine may be shared, so a single run says little)."""

from __future__ import annotations

import math
import os
import statistics
from collections.abc import Sequence
from typing import Any, Literal

__all__ = ["REPEATS", "best_and_median", "ceiling_summary", "load_average", "median_interval"]

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


def median_interval(
    values: Sequence[float], confidence: float = 0.95
) -> tuple[float, float] | None:
    """The narrowest pair of order statistics (k-th lowest, k-th highest) that holds the
    true median with at least `confidence` whatever the distribution (binomial, so no
    resampling and no randomness), or None when there are too few runs (under 6 at 95%)."""
    xs = sorted(values)
    n = len(xs)
    found = None
    below = 0  # ways for at most k-1 runs to fall below the median (it then lies below x(k))
    for k in range(1, n // 2 + 1):
        below += math.comb(n, k - 1)
        if 1 - 2 * below / 2**n < confidence:
            break
        found = (xs[k - 1], xs[n - k])
    return found


def ceiling_summary(
    rounds: Sequence[Sequence[dict[str, Any]]],
    k: int,
    load: float,
    size: int,
    mb_of: Literal["best", "median"] = "best",
) -> dict[str, Any]:
    """Measurement `k` of a throughput benchmark over its rounds: best and median rate
    (`msg_per_s`), MB/s of the best or median rate for messages of `size` bytes, the share
    of the same round's ceiling (measurement 0) with a 95% interval of its median (from 6
    rounds up; none for the ceiling itself) and the worst `loss` seen."""
    runs = [rnd[k] for rnd in rounds]
    best, median = best_and_median([r["msg_per_s"] for r in runs])
    shares = [
        r["msg_per_s"] / max(rnd[0]["msg_per_s"], 1e-9) for r, rnd in zip(runs, rounds, strict=True)
    ]
    share_best, share_median = best_and_median(shares)
    interval = median_interval(shares) if k else None
    return {
        "direction": runs[0]["direction"],
        "payload": runs[0]["payload"],
        "sent": runs[0]["sent"],
        "load_1min": load,
        "msg_per_s_best": best,
        "msg_per_s_median": median,
        f"mb_per_s_{mb_of}": (best if mb_of == "best" else median) * size / 1e6,
        "of_ceiling_best": share_best,
        "of_ceiling_median": share_median,
        "of_ceiling_95ci": f"{interval[0]:.3f}-{interval[1]:.3f}" if interval else "",
        "loss_worst": max(r["loss"] for r in runs),
    }
