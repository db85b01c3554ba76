"""The perception benchmark's stage table from six made-up rounds: sums, the cost rows and
the 95% interval of their medians (from 6 rounds: the lowest and highest round)."""

from __future__ import annotations

from typing import Any

from benchmarks.bench_perception import WRITE_BOP, WRITE_NATIVE, stage_rows

POSE = "pose (randomisers, mj_forward)"
IMAGE = "image randomisers (background, noise)"


def _round(render: float, labels: float) -> dict[str, Any]:
    return {
        "ms": {
            "RGB render": render,
            IMAGE: 5.0,
            "labels (annotate)": labels,
            POSE: 2.0,
            WRITE_NATIVE: 8.0,
            WRITE_BOP: 10.0,
        },
        "renders": ["RGB render"],
        "image": IMAGE,
    }


def test_cost_rows_give_the_median_and_its_interval_over_the_rounds() -> None:
    # Bare renders (pose + renders) of 50 ms; native labelling and writing 13 + labels ms.
    rounds = [_round(48.0, labels) for labels in (1.0, 2.0, 0.0, 4.0, 3.0, 2.0)]
    rows = {row["stage"]: row for row in stage_rows(rounds)}
    native = rows["labelling + writing, native only over the bare renders (pose + renders)"]
    assert native["cpu_ms_median"] == "+30%"  # (13 + 2) / 50
    assert native["cpu_ms_least"] == "+26%"
    assert native["median_95ci"] == "+26% to +34%"
    everything = rows["labelling + writing over the bare renders (pose + renders)"]
    assert everything["median_95ci"] == "+46% to +54%"  # BOP's 10 ms more
    assert rows["labels (annotate)"]["median_95ci"] == "0.0 to 4.0"
    assert rows["sum of the renders"]["frames_per_s_bound"] == round(1000 / 48, 2)


def test_under_six_rounds_there_is_no_interval() -> None:
    rows = stage_rows([_round(48.0, 1.0)] * 5)
    assert all(row["median_95ci"] == "" for row in rows)
