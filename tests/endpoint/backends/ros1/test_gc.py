"""The ros1 backend leaves its startup objects out of garbage collection (`speed.gc_tuning`), as
the ros2 backend does: rospy, its message modules and the node are walked by no later
collection. Runs in a child process, so the freeze does not reach the test process."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import pytest
from tests.ros1support import RosMaster

pytestmark = [pytest.mark.ros1, pytest.mark.timeout(120)]

_SCRIPT = textwrap.dedent(
    """
    import asyncio, gc, json
    from simbridge.endpoint.backends.ros1 import Ros1Backend, Ros1Options

    async def main():
        backend = Ros1Backend(Ros1Options(node_name="sb_gc_probe", forward_logs=False))
        before = len(gc.get_objects())
        await backend.start()
        walked, frozen = len(gc.get_objects()), gc.get_freeze_count()
        await backend.close()
        print(json.dumps({"before": before, "walked": walked, "frozen": frozen}), flush=True)

    asyncio.run(main())
    """
)


def test_start_freezes_the_startup_objects(master: RosMaster) -> None:
    """After start() a full collection walks a small fraction of the process's objects;
    before it, it walked them all."""
    done = subprocess.run(
        [sys.executable, "-c", _SCRIPT],
        env=master.env,
        capture_output=True,
        text=True,
        timeout=90,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["frozen"] >= result["before"], result
    assert result["walked"] * 20 < result["frozen"], result
