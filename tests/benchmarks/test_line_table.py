"""The line delivery table's rows come from the demo's JSON summary, and the summary row
counts a seed that failed (no summary) as nothing delivered."""

from __future__ import annotations

from benchmarks.line_table import delivery_row, summary_row

from simbridge.apps.line import LineResult


def test_rows_from_the_json_summary_and_a_failed_seed() -> None:
    delivered = LineResult(
        parts=3, delivered=3, placement_error_m=(0.003, 0.0041, 0.002), cycle_s=12.5,
        sim_s=40.0, wall_s=8.0, robots={}, cpu_s=10.0, seed=4, backend="ros2",
    ).to_dict()  # fmt: skip
    failed = {"parts": 3, "delivered": 0, "placement_error_m": [], "cycle_s": 0.0,
              "sim_s": 0.0, "wall_s": 0.0, "realtime_factor": 0.0, "cpu_s": 0.0,
              "error": "process exited (1) before the summary"}  # fmt: skip
    rows = [delivery_row(4, delivered), delivery_row(5, failed)]
    assert rows[0] == {
        "seed": 4, "delivered": "3/3", "worst_error_cm": 0.41, "cycle_s": 12.5, "sim_s": 40.0,
        "wall_s": 8.0, "rtf": 5.0, "rtf_cpu": 4.0, "error": "",
    }  # fmt: skip
    assert (rows[1]["delivered"], rows[1]["rtf_cpu"]) == ("0/3", 0.0)
    assert rows[1]["error"].startswith("process exited (1)")
    total = summary_row(rows, 3)
    assert total["delivered"] == "3/6 (50%)"
    assert total["worst_error_cm"] == 0.41
    assert total["rtf"] == 2.5  # the median of 5.0 and 0.0
