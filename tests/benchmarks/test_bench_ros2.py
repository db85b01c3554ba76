"""bench_ros2's node processes: their answers are read past Fast DDS's own log lines; its
CPU sampler counts the processes it watches and not itself."""

from __future__ import annotations

import math
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


def test_cpu_row_gives_medians_each_round_and_the_bound_against_the_same_round_s_ceiling() -> None:
    """`--cpu`'s summary of one row: medians of the rate and each process's CPU, every
    round's rate and CPU sum (the Twist rounds are bimodal), and the share of the ceiling
    the CPU allows, each round against its own ceiling."""
    bench = pytest.importorskip("benchmarks.bench_ros2")

    def row(rate: float, cpu: dict[str, float]) -> dict[str, object]:
        return {"direction": "d", "payload": "Twist 48 B", "msg_per_s": rate, "loss": 0.0,
                "cpu_us": cpu}  # fmt: skip

    runs = [
        [row(50000, {"pub": 12, "sub": 13}), row(40000, {"c": 5, "e": 15, "sub": 30})],
        [row(20000, {"pub": 30, "sub": 30}), row(30000, {"c": 6, "e": 14, "sub": 20})],
        [row(40000, {"pub": 15, "sub": 15}), row(10000, {"c": 7, "e": 40, "sub": 53})],
    ]
    out = bench._cpu_row(runs, 1, 0.5, 2)
    assert out["payload"] == "Twist 48 B"
    assert out["msg_per_s_median"] == 30000
    assert out["of_ceiling_median"] == pytest.approx(0.8)  # 0.8, 1.5, 0.25
    assert out["cpu_us_per_msg_median"] == {"c": 6, "e": 15, "sub": 30}
    assert out["cpu_us_sum_median"] == 50
    assert out["rounds_msg_per_s_cpu_us"] == [(40000, 50), (30000, 40), (10000, 100)]
    assert out["bound_msg_per_s_2_cores"] == pytest.approx(40000)
    assert out["bound_of_ceiling_median"] == pytest.approx(0.5)  # 25/50, 60/40, 30/100


def test_latency_row_takes_each_round_against_its_own_reference() -> None:
    """The round-trip rows: percentiles in ms over each run, best and median over the
    runs, and p50/p99 ratios round by round against the reference (rclpy) run."""
    bench = pytest.importorskip("benchmarks.bench_ros2")
    ms = 1e-3
    reference = [[1 * ms] * 100, [2 * ms] * 100, [1 * ms] * 100]
    runs = [[3 * ms] * 100, [3 * ms] * 100, [1.5 * ms] * 99 + [9 * ms]]
    row = bench.latency_row("endpoint", runs, reference, 0.5)
    assert row["returned_worst"] == 100
    assert row["p50_ms_best"] == pytest.approx(1.5)
    assert row["p50_ms_median"] == pytest.approx(3)
    assert row["p50_ms_vs_rclpy"] == pytest.approx(1.5)  # 3, 1.5, 1.5
    assert row["p99_ms_vs_rclpy"] == pytest.approx(3)  # 3, 1.5, 9
    assert row["max_ms_best"] == pytest.approx(3)
    assert "max_ms_vs_rclpy" not in row
    empty = bench.latency_row("lost all", [[]], [[1 * ms]], 0.5)
    assert empty["returned_worst"] == 0
    assert math.isnan(empty["p50_ms_median"])


def test_rclpy_reference_round_trip_gets_every_ping_back_from_a_real_echo_node(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The reference row's pinger against the bench's rclpy echo node (real processes,
    this test's own ROS domain): every ping returns once, in a plausible time."""
    bench = pytest.importorskip("benchmarks.bench_ros2")
    from tests.ros2support import child_env

    monkeypatch.setattr(bench, "LATENCY_COUNT", 30)
    script = tmp_path / "node.py"
    script.write_text(bench._NODE_SCRIPT % {"idle": bench.IDLE_END, "rate": bench.LATENCY_RATE})
    twist = tmp_path / "twist.bin"
    twist.write_bytes(bench._twist())
    rtts = bench._rclpy_latency(child_env(), script, twist, "/test_bench/rt")
    assert len(rtts) == 30
    assert all(0 < rtt < 1.0 for rtt in rtts), rtts


@pytest.mark.parametrize("kind", ["Twist", "Image"])
def test_the_sim_node_row_counts_every_message_from_the_sim_s_own_node(
    tmp_path: Path, kind: str
) -> None:
    """The "sim -> ros2 (in-process node)" row: bench_ros2_sim_node.py publishes through a
    Ros2SimNode (real processes, this test's own ROS domain) to the bench's rclpy
    subscriber, which counts every message (a Twist, an image published in place)."""
    bench = pytest.importorskip("benchmarks.bench_ros2")
    from tests.ros2support import child_env

    data = bench._twist() if kind == "Twist" else bench._image(320, 240)
    p = bench.Payload(kind, f"{'geometry' if kind == 'Twist' else 'sensor'}_msgs/{kind}", data, 40)
    script = tmp_path / "node.py"
    script.write_text(bench._NODE_SCRIPT % {"idle": bench.IDLE_END, "rate": bench.LATENCY_RATE})
    payload = tmp_path / "payload.bin"
    payload.write_bytes(data)
    row = bench._ceiling(
        child_env(), script, payload, p, f"/test_bench/node_{kind}", publisher=bench.SIM_NODE
    )
    assert row["direction"] == "sim -> ros2 (in-process node)"
    assert (row["sent"], row["received"], row["loss"]) == (40, 40, 0)
