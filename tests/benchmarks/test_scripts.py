"""Benchmarks that import `benchmarks.*` run both as bare scripts and as modules: their
`--help` prints the docstring and exits before measuring anything; a benchmark's `--quick`
mode runs it end to end in seconds."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.ros2support import require_ros2

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = (
    "bench_ros1",
    "bench_ros2",
    "bench_drain",
    "bench_line_ros2",
    "bench_sim",
    "bench_attacks",
    "bench_ray",
    "bench_perception",
)
ROS2_SCRIPTS = ("bench_ros2", "bench_drain", "bench_line_ros2")
"""Scripts that refuse to load without the ROS 2 venv."""


def _run(
    args: list[str], cwd: Path, option: str = "--help", timeout: float = 120
) -> subprocess.CompletedProcess[str]:
    if any(name in args[-1] for name in ROS2_SCRIPTS):
        require_ros2()  # the module refuses to load without the ROS 2 venv
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run(
        [sys.executable, *args, option],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
        stdin=subprocess.DEVNULL,
        check=False,
    )


@pytest.mark.parametrize("name", SCRIPTS)
def test_bare_script_help(name: str, tmp_path: Path) -> None:
    """`python benchmarks/bench_NAME.py --help` from another directory: only the script's
    own directory is on sys.path, so `benchmarks` must be found from the file's place."""
    result = _run([str(ROOT / "benchmarks" / f"{name}.py")], tmp_path)
    assert result.returncode == 0, result.stderr
    first_line = (ROOT / "benchmarks" / f"{name}.py").read_text().split("\n")[0]
    assert result.stdout.startswith(first_line.removeprefix('"""'))
    assert result.stderr == ""


@pytest.mark.parametrize("name", SCRIPTS)
def test_module_help(name: str) -> None:
    result = _run(["-m", f"benchmarks.{name}"], ROOT)
    assert result.returncode == 0, result.stderr
    assert "options:" in result.stdout


def test_perception_quick_mode_measures_every_mode_and_stage(tmp_path: Path) -> None:
    """`bench_perception.py --quick`: one round of two frames at the fast quality, in one
    fresh process: the frames/s table's four modes and the stage table with its sums."""
    result = _run([str(ROOT / "benchmarks" / "bench_perception.py")], tmp_path, "--quick", 600)
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert "### Perception: frames/s on one core" in out
    assert "### Perception: CPU per labelled frame, by stage (fast)" in out
    assert "(high)" not in out  # quick: the fast preset alone
    rows = {line.split("  ")[0].strip(): line for line in out.splitlines()}
    for mode in ("RGB render only", "RGB + depth + segmentation", "labelled + written, native",
                 "labelled + written (native, COCO, BOP)"):  # fmt: skip
        assert sum(mode in line and line.startswith("fast") for line in out.splitlines()) == 1
    for stage in ("render: RGB render", "image randomisers (background, noise)",
                  "labels (annotate)", "write: native (", "write: BOP (", "sum of the renders",
                  "sum of all stages"):  # fmt: skip
        assert any(row.startswith(stage) for row in rows), stage
    for what in ("", ", native only"):
        for under in ("the bare renders (pose + renders)",
                      "the frames (pose + renders + image randomisers)"):  # fmt: skip
            over = rows[f"labelling + writing{what} over {under}"].split()
            assert any(cell.startswith("+") and cell.endswith("%") for cell in over), what
