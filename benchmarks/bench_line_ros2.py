"""The line demo over ROS 2 (`simbridge demo line --backend ros2`) for the same seeds and
parts as the local line table (benchmarks/bench_line.py), so the two compare row by row.

Each seed is one `simbridge demo line --backend ros2 --parts 3 --seed S --json` process run
with the ROS 2 venv's Python in a ROS domain of its own, localhost only (tests/ros2support.py):
the sim and the endpoint in that process, the robots driven only through the controllers'
ROS 2 actions by plain rclpy ActionClients in a process of their own. A row is the demo's
JSON summary (its last line): parts delivered within 2 cm, worst error, simulated seconds per
part, the run's sim and wall seconds (the sim's run, planning pauses included; not the
processes' start-up) and its real-time factor; `rtf_cpu` per CPU second of the sim's process
(the driving process not counted). A seed without a summary counts as 0 delivered, with the
reason as its error; a failed seed's last output lines are printed. Run alone:
`python benchmarks/bench_line_ros2.py [--quick] [--markdown]` (`--quick`: 1 seed, 1 part).
"""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # also as a bare script

from benchmarks.line_table import PARTS, SEEDS, delivery_row, summary_row
from simbridge.endpoint.backends.ros2 import ros2_python

__all__ = ["run"]

if ros2_python() is None:  # benchmarks/run.py reports the suite as skipped
    raise ModuleNotFoundError("the ROS 2 venv (.venv-ros2) is missing: run `make ros2`")

SEED_TIMEOUT_S = 1200.0
"""Wall seconds one seed's demo may take before it is stopped and counted as failed."""


def _seed(seed: int, parts: int) -> dict[str, Any]:
    """One demo process: its JSON summary, or a failed one saying why there was none."""
    from tests.ros2support import Ros2Process

    command = ["-m", "simbridge.cli", "demo", "line", "--backend", "ros2"]
    with Ros2Process([*command, "--parts", str(parts), "--seed", str(seed), "--json"]) as demo:
        try:  # the summary is the last line; the process then leaves ROS 2 and exits
            line = demo.expect_line(r'^\{"success"', timeout=SEED_TIMEOUT_S).string
            with contextlib.suppress(subprocess.TimeoutExpired):  # then stopped on exit
                demo.proc.wait(60)
            summary: dict[str, Any] = json.loads(line)
            if not summary["success"]:  # the run's log keeps why (the table cuts the error)
                print(f"seed {seed} failed:\n{''.join(demo.output[-30:])}", flush=True)
            return summary
        except AssertionError as exc:  # Ros2Process: exited or timed out before the line
            print(f"seed {seed}: no summary:\n{exc}", flush=True)
            why = str(exc).splitlines()[0]
    return {
        "success": False, "parts": parts, "delivered": 0, "placement_error_m": [],
        "cycle_s": 0.0, "sim_s": 0.0, "wall_s": 0.0, "realtime_factor": 0.0, "cpu_s": 0.0,
        "error": why,
    }  # fmt: skip


def run(seeds: tuple[int, ...] = SEEDS, parts: int = PARTS) -> dict[str, list[dict[str, Any]]]:
    """The delivery table over ``seeds``, with the 1-minute load average's range in its
    title (the machine may be shared)."""
    rows: list[dict[str, Any]] = []
    loads = [os.getloadavg()[0]]
    for seed in seeds:
        rows.append(delivery_row(seed, _seed(seed, parts)))
        loads.append(os.getloadavg()[0])
        print(rows[-1], flush=True)
    title = (
        f"Line demo over ROS 2 (`demo line --backend ros2`), {len(seeds)} seeds x {parts} "
        f"parts (target: >= 95% delivered within 2 cm); 1-minute load {min(loads):.1f}-"
        f"{max(loads):.1f}"
    )
    return {title: [*rows, summary_row(rows, parts)]}


if __name__ == "__main__":
    from benchmarks.table import format_table
    from benchmarks.usage import exit_on_help

    exit_on_help(
        __doc__,
        "  --quick     1 seed, 1 part (a check that it runs)\n  --markdown  Markdown tables",
    )
    quick = "--quick" in sys.argv
    for title, table in run(SEEDS[:1] if quick else SEEDS, 1 if quick else PARTS).items():
        print(f"### {title}\n")
        print(format_table(table, markdown="--markdown" in sys.argv) + "\n")
