"""Fast DDS shared-memory files: a killed participant's are found and removed.

The cleaner leaves files younger than its `min_age` alone (a participant starting this
instant has not locked or mapped them yet), so these tests age their own files instead of
calling it with no minimum age: files of another suite running beside this one are safe."""

from __future__ import annotations

import mmap
import os
import secrets
import signal
import time
from pathlib import Path

import pytest
from tests.ros2support import Ros2Process

from simbridge.endpoint.backends.ros2 import clean_stale_shm

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(120)]

SHM = Path("/dev/shm")


def _age(names: set[str] | list[str]) -> None:
    """Set the files' times an hour back: old enough for `clean_stale_shm` to judge."""
    hour_ago = time.time() - 3600
    for name in names:
        os.utime(SHM / name, (hour_ago, hour_ago))


def _locks_held_by(pid: int) -> set[str]:
    """The Fast DDS `_el` lock files in /dev/shm whose flock `pid` holds (from /proc/locks),
    so files of other processes running at the same time are never counted as this one's."""
    inodes: set[int] = set()
    for line in Path("/proc/locks").read_text().splitlines():
        fields = line.split()
        if len(fields) >= 6 and fields[1] == "FLOCK" and fields[4] == str(pid):
            inodes.add(int(fields[5].rsplit(":", 1)[1]))
    held = set()
    for lock in SHM.glob("fastrtps_*_el"):
        try:
            if lock.stat().st_ino in inodes:
                held.add(lock.name)
        except FileNotFoundError:
            continue
    return held


def test_files_of_a_killed_node_are_cleaned() -> None:
    node = Ros2Process.node("serve", "/sb_shm", "std_srvs/srv/Trigger", "{}")
    try:
        node.expect_json("ready")
        locks = _locks_held_by(node.proc.pid)
        assert locks, "the node holds no Fast DDS lock file"
        bases = [name[: -len("_el")] for name in locks]
        mine = {f for b in bases for f in (b, f"{b}_el", f"sem.{b}_mutex") if (SHM / f).exists()}
        _age(mine)
        assert not set(clean_stale_shm()) & mine, "a live node's files were removed"
        os.killpg(node.proc.pid, signal.SIGKILL)  # no chance to clean up
        node.proc.wait(10)
    finally:
        node.stop()
    time.sleep(0.2)
    left_behind = {f for f in mine if (SHM / f).exists()}
    assert left_behind, "a SIGKILLed node left nothing: the check below proves nothing"
    removed = set(clean_stale_shm())
    assert left_behind <= removed
    assert not any((SHM / f).exists() for f in left_behind)


def test_port_segments_nobody_maps_are_removed_and_mapped_ones_kept() -> None:
    """Fast DDS never deletes its `fastrtps_port<N>` segments; a stale one (mapped by no
    process) goes, with its mutex, while one a process maps stays."""
    stale, live = (f"fastrtps_port9{secrets.randbelow(10**6):06d}{i}" for i in range(2))
    paths = [SHM / name for name in (stale, f"sem.{stale}_mutex", live, f"sem.{live}_mutex")]
    for path in paths:
        path.write_bytes(bytes(4096))
    _age([path.name for path in paths])
    try:
        with open(SHM / live, "r+b") as f, mmap.mmap(f.fileno(), 4096):
            removed = clean_stale_shm()
            assert {stale, f"sem.{stale}_mutex"} <= set(removed)
            assert (SHM / live).exists(), "a mapped port segment was removed"
    finally:
        for path in paths:
            path.unlink(missing_ok=True)
