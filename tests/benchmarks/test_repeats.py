"""benchmarks.repeats.ceiling_summary: one throughput row from interleaved rounds."""

from __future__ import annotations

import pytest
from benchmarks.repeats import ceiling_summary


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
