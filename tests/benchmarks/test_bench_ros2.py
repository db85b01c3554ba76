"""bench_ros2's node processes: their answers are read past Fast DDS's own log lines."""

from __future__ import annotations

import os
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
