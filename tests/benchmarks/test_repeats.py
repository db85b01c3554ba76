"""benchmarks.repeats.ceiling_summary: one throughput row from interleaved rounds."""

from __future__ import annotations

import math
import random

import pytest
from benchmarks.repeats import ceiling_summary, median_interval


def _run(direction: str, rate: float, loss: int) -> dict[str, object]:
    return {
        "direction": direction,
        "payload": "Twist",
        "sent": 1000,
        "msg_per_s": rate,
        "loss": loss,
    }


def test_rates_shares_of_the_same_rounds_ceiling_and_worst_loss() -> None:
    rounds = [
        [_run("ceiling", 1000.0, 0), _run("sim->ros", 900.0, 0)],
        [_run("ceiling", 2000.0, 0), _run("sim->ros", 1000.0, 3)],
        [_run("ceiling", 1000.0, 0), _run("sim->ros", 800.0, 1)],
    ]
    row = ceiling_summary(rounds, 1, 0.5, size=48)
    assert row["direction"] == "sim->ros"
    assert (row["msg_per_s_best"], row["msg_per_s_median"]) == (1000.0, 900.0)
    assert row["mb_per_s_best"] == pytest.approx(1000 * 48 / 1e6)
    assert (row["of_ceiling_best"], row["of_ceiling_median"]) == (0.9, 0.8)  # 0.9, 0.5, 0.8
    assert row["loss_worst"] == 3
    assert row["load_1min"] == 0.5
    median_row = ceiling_summary(rounds, 1, 0.5, size=48, mb_of="median")
    assert "mb_per_s_best" not in median_row
    assert median_row["mb_per_s_median"] == pytest.approx(900 * 48 / 1e6)
    assert list(median_row)[6] == "mb_per_s_median"  # the column sits after the rates


def test_median_interval_is_the_narrowest_order_statistics_that_cover_95_percent() -> None:
    # n=9: P(x(2) <= median <= x(8)) = 1 - 2 * 10/512 = 0.961; x(3)..x(7) only 0.820
    assert median_interval([9.0, 1.0, 8.0, 2.0, 7.0, 3.0, 6.0, 4.0, 5.0]) == (2.0, 8.0)
    # n=6: only min..max (0.969); n=5 cannot reach 95% (min..max 0.9375)
    assert median_interval([3.0, 1.0, 2.0, 6.0, 5.0, 4.0]) == (1.0, 6.0)
    assert median_interval([1.0, 2.0, 3.0, 4.0, 5.0]) is None
    assert median_interval([1.0, 2.0, 3.0, 4.0, 5.0], confidence=0.9) == (1.0, 5.0)


def test_median_interval_covers_the_true_median_as_often_as_it_says() -> None:
    rng = random.Random(7)
    for n in (6, 9, 20):
        hits = 0
        for _ in range(4000):
            interval = median_interval([rng.expovariate(1.0) for _ in range(n)])
            assert interval is not None
            hits += interval[0] <= math.log(2) <= interval[1]  # the exponential's median
        assert 0.95 <= hits / 4000 <= 0.995


def test_the_row_gives_the_interval_from_six_rounds() -> None:
    rounds = [[_run("ceiling", 1000.0, 0), _run("x", 900.0 + 10 * i, 0)] for i in range(9)]
    assert ceiling_summary(rounds, 1, 0.5, size=48)["of_ceiling_95ci"] == "0.910-0.970"
    assert ceiling_summary(rounds[:5], 1, 0.5, size=48)["of_ceiling_95ci"] == ""
    assert ceiling_summary(rounds, 0, 0.5, size=48)["of_ceiling_95ci"] == ""  # the ceiling
