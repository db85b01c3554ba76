"""The ros2 backend leaves its startup objects out of garbage collection (`speed.gc_tuning`).

Runs in a ROS 2 venv child: a started backend, then what a full collection would walk
(`gc.get_objects()`, which leaves out the frozen generation) beside what is frozen.
"""

from __future__ import annotations

import textwrap

import pytest
from tests.ros2support import Ros2Process

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(120)]

_SCRIPT = textwrap.dedent(
    """
    import asyncio, gc, json
    from simbridge.endpoint.backends.ros2 import Ros2Backend, Ros2Options

    async def main():
        backend = Ros2Backend(Ros2Options(node_name="sb_gc_probe"))
        before = len(gc.get_objects())
        await backend.start()
        walked, frozen = len(gc.get_objects()), gc.get_freeze_count()
        await backend.close()
        print(json.dumps({"gc": {"before": before, "walked": walked, "frozen": frozen}}),
              flush=True)

    asyncio.run(main())
    """
)


def test_start_freezes_the_startup_objects() -> None:
    """After start() a full collection walks a small fraction of the process's objects
    (rclpy, the message modules and the node are frozen); before it walked them all."""
    with Ros2Process(["-c", _SCRIPT]) as proc:
        result = proc.expect_json("gc", timeout=60)
    assert result["frozen"] >= result["before"], result
    assert result["walked"] * 20 < result["frozen"], result
