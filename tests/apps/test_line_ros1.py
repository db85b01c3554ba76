"""`simbridge demo line --backend ros1`: every robot's joint states and action traffic are
real ROS 1 topics on the master while the parts move, and the parts still arrive."""

from __future__ import annotations

import json
import sys
import time
import xmlrpc.client
from typing import Any

import pytest

from tests.ros1support import RosMaster, require_ros, terminate

pytestmark = [
    pytest.mark.ros1,
    pytest.mark.timeout(300),
    pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning"),
]


def _publishers(master: RosMaster, topic: str) -> list[str]:
    reply: Any = xmlrpc.client.ServerProxy(master.uri).getSystemState("/test_line_ros1")
    return [node for name, nodes in reply[2][0] for node in nodes if name == topic]


def test_line_moves_parts_over_real_ros_topics() -> None:
    require_ros()
    with RosMaster() as master:
        demo = master.spawn(
            [sys.executable, "-m", "simbridge.cli", "demo", "line", "--backend", "ros1",
             "--parts", "1", "--seed", "2", "--json"]
        )  # fmt: skip
        try:
            topics = [f"/{robot}/joint_states" for robot in ("arm_in", "arm_out", "conveyor")]
            topics += ["/arm_in/arm_controller/follow_joint_trajectory/feedback"]
            deadline = time.monotonic() + 120
            while not all(_publishers(master, topic) for topic in topics):
                assert demo.poll() is None, demo.communicate()
                assert time.monotonic() < deadline, f"the line never published {topics}"
                time.sleep(0.1)
            (node,) = _publishers(master, "/arm_out/joint_states")
            assert node.startswith("/simbridge_line_")
            kind = master.run(["rostopic", "type", "/conveyor/joint_states"])
            assert kind.stdout.strip() == "sensor_msgs/JointState"
            out, err = demo.communicate(timeout=240)
        finally:
            terminate(demo)
    assert demo.returncode == 0, out + err
    summary = json.loads(out.strip().splitlines()[-1])
    assert summary["success"] is True
    assert summary["delivered"] == 1
    assert "ros1 backend, ROS master" in out
