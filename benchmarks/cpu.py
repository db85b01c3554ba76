"""CPU time of a process from /proc, for benchmarks that report what a figure cost."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

__all__ = ["process_cpu_ns"]


def process_cpu_ns(pid: int, skip_thread: int = -1) -> int:
    """Nanoseconds every thread of `pid` (but `skip_thread`, a native thread id) has run,
    user and system, from each thread's schedstat; 0 once the process is gone."""
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return 0
    total = 0
    for task in tasks:
        if int(task) == skip_thread:
            continue
        with contextlib.suppress(OSError, IndexError, ValueError):  # a thread that just ended
            total += int(Path(f"/proc/{pid}/task/{task}/schedstat").read_text().split()[0])
    return total
