"""DrainedProcess (what RosCore.spawn starts): a spawned process's pipes are read all the
time into bounded tails, so a process that writes more than a pipe holds never blocks."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from simbridge.endpoint.backends.ros1 import DrainedProcess, RosCore

CHATTY = "import sys; sys.stderr.write('e' * 300_000 + 'last err'); print('x' * 300_000 + 'end')"


def test_a_chatty_process_finishes_and_its_tails_are_bounded() -> None:
    """300 kB on each stream (several pipe buffers): it exits though nobody reads early,
    and each tail keeps `limit` characters, saying how many it dropped."""
    process = DrainedProcess([sys.executable, "-c", CHATTY], env={}, limit=1000)
    out, err = process.communicate(timeout=30)
    assert process.returncode == 0
    assert out.endswith("x" * 996 + "end\n")
    assert out.startswith("[... 299004 earlier characters dropped ...]\n")
    assert err.endswith("last err")
    assert "299008 earlier characters dropped" in err


def test_output_so_far_and_timeout_like_popen() -> None:
    code = "import time; print('ready', flush=True); time.sleep(30)"
    process = DrainedProcess([sys.executable, "-c", code], env={})
    try:
        with pytest.raises(subprocess.TimeoutExpired):
            process.communicate(timeout=0.2)
        deadline = time.monotonic() + 10
        while process.output()[0] != "ready\n" and time.monotonic() < deadline:
            time.sleep(0.05)
        assert process.output() == ("ready\n", "")
    finally:
        process.kill()
        process.wait()


def test_roscore_spawn_never_blocks_on_a_full_pipe() -> None:
    """RosCore.spawn (no master needed to start a process): 300 kB on each stream finishes
    though nobody reads until it has exited (a plain PIPE would hold it at 64 KiB)."""
    core = RosCore()
    try:
        process = core.spawn([sys.executable, "-c", CHATTY])
        assert isinstance(process, DrainedProcess)
        assert process.wait(timeout=30) == 0
        out, err = process.communicate(timeout=5)
        assert out.endswith("end\n")
        assert len(out) == 300_004
        assert err.endswith("last err")
    finally:
        core.stop()
