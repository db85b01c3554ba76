"""bench_ros2's node processes: their answers are read past Fast DDS's own log lines; its
CPU sampler counts the processes it watches and not itself."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest


def test_node_answers_are_read_past_fast_dds_log_lines(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A Fast DDS error printed on stdout (as when another process holds a shared-memory
    port) went to the bench as the node's answer and failed `READY` checks."""
    bench = pytest.importorskip("benchmarks.bench_ros2")
    script = tmp_path / "node.py"
    log_line = (
        "\\x1b[37;1m2026-11-23 03:18:36.384 [RTPS_TRANSPORT_SHM Error] "
        "Failed init_port fastrtps_port7002: open_and_lock_file failed"
    )
    script.write_text(
        f'print("{log_line}", flush=True)\n'
        'print("READY", flush=True)\n'
        'print("", flush=True)\n'
        "print('{\"sent\": 3}', flush=True)\n"
    )
    proc = bench._Proc([str(script), "pub"], dict(os.environ))
    try:
        assert proc.line(timeout=30) == "READY"
        assert proc.line(timeout=30) == '{"sent": 3}'
    finally:
        proc.proc.wait(10)
    assert "[bench node pub]" in capsys.readouterr().err


def test_cpu_sampler_counts_a_process_s_cpu_time_not_its_own() -> None:
    """`--cpu`'s sampler: a child that burns 0.4 s of CPU (by its own clock) counts about
    that much over a window around it; this process, idle but for the sampling thread,
    counts next to nothing (the sampler leaves its own thread out)."""
    bench = pytest.importorskip("benchmarks.bench_ros2")
    burn = (
        "import sys, time\n"
        "print('ready', flush=True); sys.stdin.readline()\n"
        "t = time.process_time()\n"
        "while time.process_time() - t < 0.4: pass\n"
        "print('done', flush=True); sys.stdin.readline()\n"
    )
    child = subprocess.Popen(
        [sys.executable, "-c", burn], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    assert child.stdin is not None
    assert child.stdout is not None
    try:
        assert child.stdout.readline() == "ready\n"
        sampler = bench._CpuSampler({"child": child.pid, "self": os.getpid()})
        start = time.perf_counter()
        child.stdin.write("go\n")
        child.stdin.flush()
        assert child.stdout.readline() == "done\n"
        time.sleep(0.05)
        cpu = sampler.span(start, time.perf_counter(), 1)
    finally:
        child.kill()
        child.wait(10)
    assert 0.38e6 <= cpu["child"] <= 0.6e6, cpu
    assert cpu["self"] < 0.1e6, cpu
