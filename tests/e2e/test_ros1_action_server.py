"""The connector's action client against Debian's real actionlib SimpleActionServer (a
rospy node with genpy control_msgs) through `simbridge endpoint --backend ros1`: result,
feedback, cancel and preemption by a newer goal."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path
from typing import Any

import pytest
from tests.ros1support import (
    SYSTEM_PYTHON,
    EndpointProcess,
    RosMaster,
    require_ros,
    terminate,
)
from tests.waiting import wait_for

from simbridge.connector import ActionClient, Connector, ConnectorOptions
from simbridge.endpoint.backends.ros1 import generate_python_messages
from simbridge.messages import default_registry
from simbridge.messages.actionlib import ACTIVE, PREEMPTED, SUCCEEDED

require_ros(module_level=True)

pytestmark = [pytest.mark.ros1, pytest.mark.timeout(240)]

REG = default_registry()
ACTION = "control_msgs/GripperCommand"

SERVER_NODE = r"""
import time
import actionlib, rospy
from control_msgs.msg import GripperCommandAction, GripperCommandFeedback, GripperCommandResult

rospy.init_node("gripper_server", disable_signals=True)

def execute(goal):
    deadline = time.monotonic() + goal.command.max_effort  # seconds to "close"
    while time.monotonic() < deadline:
        if server.is_preempt_requested():
            server.set_preempted(GripperCommandResult(position=-1.0))
            return
        server.publish_feedback(GripperCommandFeedback(position=goal.command.position / 2))
        time.sleep(0.05)
    server.set_succeeded(GripperCommandResult(position=goal.command.position, reached_goal=True))

server = actionlib.SimpleActionServer("/gripper/gripper_cmd", GripperCommandAction, execute, False)
server.start()
print("ready", flush=True)
rospy.spin()
"""


def _goal(position: float, seconds: float) -> Any:
    command = REG.new("control_msgs/GripperCommand", position=position, max_effort=seconds)
    return REG.new("control_msgs/GripperCommandGoal", command=command)


def test_connector_client_against_simple_action_server(tmp_path: Path) -> None:
    probe = subprocess.run([SYSTEM_PYTHON, "-c", "import actionlib"], check=False)
    if probe.returncode != 0:
        if os.environ.get("CI"):
            pytest.fail("python3-actionlib is not installed (make sysdeps)")
        pytest.skip("python3-actionlib is not installed (make sysdeps)")
    extra = generate_python_messages(REG, [], tmp_path / "ws", [f"{ACTION}Action"])
    with RosMaster() as master:
        env = dict(master.env)
        for key, value in extra.items():
            env[key] = os.pathsep.join(v for v in (value, env.get(key, "")) if v)
        endpoint = EndpointProcess(master, "/jtc_endpoint")
        port = endpoint.port
        server = subprocess.Popen(
            [SYSTEM_PYTHON, "-c", SERVER_NODE], env=env, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, text=True, start_new_session=True,
        )  # fmt: skip
        connector = Connector("127.0.0.1", port, ConnectorOptions()).connect(wait=10)
        try:
            assert server.stdout is not None
            assert server.stdout.readline().strip() == "ready"
            # wait_for_server returns once the status came and rospy's goal and cancel
            # subscribers connected to the endpoint's publishers, as actionlib's does: a
            # goal sent at once is never lost (ROS 1 keeps none for late subscribers)
            for _ in range(3):  # a fresh client and connection each time
                fresh = Connector("127.0.0.1", port, ConnectorOptions()).connect(wait=10)
                try:
                    first = ActionClient(fresh, "/gripper/gripper_cmd", ACTION)
                    assert first.wait_for_server(30)
                    sent = first.send_goal(_goal(0.02, 0.1))
                    assert sent.wait(20)
                    assert sent.status == SUCCEEDED
                    first.close()
                finally:
                    fresh.close()

            client = ActionClient(connector, "/gripper/gripper_cmd", ACTION)
            assert client.wait_for_server(30)

            feedback: list[Any] = []
            done = client.send_goal(_goal(0.04, 0.5), on_feedback=feedback.append)
            assert done.wait(20)
            assert done.status == SUCCEEDED
            assert done.result.position == pytest.approx(0.04)
            assert done.result.reached_goal
            assert feedback
            assert feedback[0].position == pytest.approx(0.02)

            long = client.send_goal(_goal(0.01, 30.0))
            assert wait_for(lambda: long.status == ACTIVE, timeout=20)
            long.cancel()
            assert long.wait(20)
            assert long.status == PREEMPTED
            assert long.result.position == pytest.approx(-1.0)

            older = client.send_goal(_goal(0.01, 30.0))
            assert wait_for(lambda: older.status == ACTIVE, timeout=20)
            newer = client.send_goal(_goal(0.03, 0.3))
            assert older.wait(20)
            assert older.status == PREEMPTED  # SimpleActionServer preempts for the newer goal
            assert newer.wait(20)
            assert newer.status == SUCCEEDED
            client.close()
        finally:
            connector.close()
            terminate(server)
            endpoint.stop()
