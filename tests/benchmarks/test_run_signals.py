"""`make bench` ended by SIGTERM (a CI timeout, `kill`) cleans up as Ctrl-C does: the suite
running stops its own processes (here bench_ros1's private roscore) before the runner
exits."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

from tests.ros1support import require_ros, wait_until

ROOT = Path(__file__).resolve().parents[2]


def _descendants(pid: int) -> dict[int, str]:
    """Live (not zombie) processes below `pid`: pid -> command line."""
    parents: dict[int, int] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue  # gone meanwhile
            fields = stat.rsplit(")", 1)[1].split()
            if fields[0] != "Z":
                parents[int(entry.name)] = int(fields[1])
    found, frontier = {}, [pid]
    while frontier:
        parent = frontier.pop()
        for child, its_parent in parents.items():
            if its_parent == parent and child not in found:
                try:
                    command = Path(f"/proc/{child}/cmdline").read_bytes()
                except OSError:
                    continue  # gone meanwhile
                found[child] = command.decode(errors="replace")
                frontier.append(child)
    return found


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_sigterm_ends_a_bench_run_with_its_suites_cleanup(tmp_path: Path) -> None:
    require_ros()
    env = dict(os.environ, SIMBRIDGE_BENCH_REPEATS="1")
    log = (tmp_path / "bench.log").open("wb")
    runner = subprocess.Popen(
        [sys.executable, str(ROOT / "benchmarks" / "run.py"), "--only", "ros1"],
        cwd=tmp_path,
        env=env,
        stdout=log,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    started: dict[int, str] = {}
    try:
        wait_until(
            lambda: any("rosmaster" in cmd for cmd in _descendants(runner.pid).values()),
            120,
            "the ros1 suite's roscore",
        )
        started = _descendants(runner.pid)
        runner.send_signal(signal.SIGTERM)
        assert runner.wait(60) == 128 + signal.SIGTERM
        wait_until(lambda: not any(map(_alive, started)), 30, f"the suite's processes {started}")
    finally:
        if runner.poll() is None:
            os.killpg(runner.pid, signal.SIGKILL)
            runner.wait()
        for pid in filter(_alive, started):  # nothing of the run may outlive the test
            os.kill(pid, signal.SIGKILL)
        log.close()
