"""The suite's two-worker schedule: files that run ROS 2 share one worker, each other file
runs whole on one, checked on the suite's real files and by a real two-worker pytest run."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from tests.scheduling import scope_of

ROOT = Path(__file__).resolve().parents[1]
DDS_FILES, PLAIN_FILES = 6, 6


def test_ros2_files_share_a_unit_and_other_files_are_their_own() -> None:
    seen: dict[Path, bool] = {}
    for nodeid in (
        "tests/ros2/test_ros2_sim.py::test_x",
        "tests/endpoint/backends/ros2/test_backend.py::test_y[a]",
        "tests/benchmarks/test_bench_ros2.py::test_z",
    ):
        assert scope_of(nodeid, ROOT, seen) == "dds", nodeid
    for nodeid in ("tests/test_progress.py::test_x", "tests/messages/test_rostime.py::T::test"):
        assert scope_of(nodeid, ROOT, seen) == nodeid.split("::")[0]


def test_a_two_worker_run_keeps_the_ros2_files_on_one_worker(tmp_path: Path) -> None:
    """Twelve one-test files, half of them carrying a ROS 2 sign, run with `-n 2 --dist
    loadfile` under a conftest using the suite's scheduler: pytest-xdist alone deals the
    files to both workers in turn, so the ROS 2 ones would land on both."""
    out = tmp_path / "where"
    out.mkdir()
    (tmp_path / "conftest.py").write_text(
        "from tests.conftest import pytest_xdist_make_scheduler  # noqa: F401\n"
    )
    body = (
        "import os, pathlib\n"
        "def test_one():\n"
        "    pathlib.Path({out!r}, {name!r}).write_text(os.environ['PYTEST_XDIST_WORKER'])\n"
    )
    names = [f"test_dds_{i}.py" for i in range(DDS_FILES)]
    names += [f"test_plain_{i}.py" for i in range(PLAIN_FILES)]
    for name in names:
        sign = "# pytest.mark.ros2\n" if "dds" in name else ""
        (tmp_path / name).write_text(sign + body.format(out=str(out), name=name))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-n", "2"]
    command += ["--dist", "loadfile", "-o", "addopts=", "--rootdir", str(tmp_path), str(tmp_path)]
    done = subprocess.run(
        command,
        check=False,
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    where = {name: (out / name).read_text() for name in names}
    dds_workers = {where[n] for n in names if "dds" in n}
    assert len(dds_workers) == 1, json.dumps(where, indent=1)
    assert set(where.values()) == {"gw0", "gw1"}, json.dumps(where, indent=1)
