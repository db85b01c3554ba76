"""A process's memory figures from Linux's /proc/PID/status (resident now, peak), which
belong to that process alone, unlike `ru_maxrss` (carried across exec from the parent)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["proc_status"]


def proc_status(key: str, pid: int | str = "self") -> int:
    """The `key` line of /proc/PID/status (`VmRSS`, `VmHWM`: kB there) in bytes."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) * 1024
    raise KeyError(key)
