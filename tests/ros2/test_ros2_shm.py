"""Fast DDS shared-memory files: a killed participant's are found and removed."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import pytest

from simbridge.endpoint.backends.ros2_env import clean_stale_shm
from tests.ros2support import Ros2Process

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(120)]

SHM = Path("/dev/shm")


def test_files_of_a_killed_node_are_cleaned() -> None:
    before = set(os.listdir(SHM))
    node = Ros2Process.node("serve", "/sb_shm", "std_srvs/srv/Trigger", "{}")
    try:
        node.expect_json("ready")
        mine = {f for f in set(os.listdir(SHM)) - before if f.startswith("fastrtps_")}
        assert any(f.endswith("_el") for f in mine)
        assert not set(clean_stale_shm(min_age=0)) & mine, "a live node's files were removed"
        os.killpg(node.proc.pid, signal.SIGKILL)  # no chance to clean up
        node.proc.wait(10)
    finally:
        node.stop()
    time.sleep(0.2)
    left_behind = {f for f in mine if (SHM / f).exists()}
    assert left_behind, "a SIGKILLed node left nothing: the check below proves nothing"
    removed = set(clean_stale_shm(min_age=0))
    assert left_behind <= removed
    assert not any((SHM / f).exists() for f in left_behind)
