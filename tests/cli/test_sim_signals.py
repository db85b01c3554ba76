"""`simbridge sim` stopped by SIGINT or SIGTERM: it exits cleanly and reports what ran
(the steps, sim time and wall time up to the signal), not zero steps at infinite speed."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from simbridge.apps.pick_and_place.scene import SCENE_PATH

REPORT = re.compile(
    r"simulated (?P<sim>[\d.]+) s in (?P<wall>[\d.]+) s wall "
    r"\((?P<steps>\d+) steps, (?P<factor>[\d.]+)x real time\)"
)


def _stderr_lines(proc: subprocess.Popen[str], started: threading.Event) -> list[str]:
    lines: list[str] = []

    def read() -> None:
        assert proc.stderr is not None
        for line in proc.stderr:
            lines.append(line)
            if "simulating " in line:
                started.set()

    threading.Thread(target=read, daemon=True).start()
    return lines


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_ends_the_run_with_what_ran(sig: signal.Signals, tmp_path: Path) -> None:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "osmesa")}
    cmd = [sys.executable, "-m", "simbridge.cli", "sim", str(SCENE_PATH), "--realtime", "1"]
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path
    )
    started = threading.Event()
    lines = _stderr_lines(proc, started)
    try:
        assert started.wait(60), "no 'simulating' line: " + "".join(lines)
        time.sleep(0.5)  # some real-time stepping to report
        proc.send_signal(sig)
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, "".join(lines)
    report = REPORT.search(out)
    assert report is not None, out
    sim, wall, steps = float(report["sim"]), float(report["wall"]), int(report["steps"])
    assert steps > 0
    assert wall >= 0.4
    assert sim > 0
    assert float(report["factor"]) == pytest.approx(sim / wall, rel=0.05, abs=0.01)


def test_ctrl_c_ends_the_run_even_when_sigint_was_ignored_by_the_parent(tmp_path: Path) -> None:
    """A parent that ignores SIGINT (a background job of a script; some test runners) passes
    that on to its children: the sim still ends on Ctrl-C."""
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "osmesa")}
    cmd = [sys.executable, "-m", "simbridge.cli", "sim", str(SCENE_PATH), "--realtime", "1"]
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=tmp_path,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),  # noqa: PLW1509
    )
    started = threading.Event()
    lines = _stderr_lines(proc, started)
    try:
        assert started.wait(60), "no 'simulating' line: " + "".join(lines)
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, "".join(lines)
    assert REPORT.search(out) is not None, out
