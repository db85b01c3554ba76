"""Benchmarks that import `benchmarks.*` run both as bare scripts and as modules: their
`--help` prints the docstring and exits before measuring anything."""

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
)
ROS2_SCRIPTS = ("bench_ros2", "bench_drain", "bench_line_ros2")
"""Scripts that refuse to load without the ROS 2 venv."""


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    if any(name in args[-1] for name in ROS2_SCRIPTS):
        require_ros2()  # the module refuses to load without the ROS 2 venv
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run(
        [sys.executable, *args, "--help"],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
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
