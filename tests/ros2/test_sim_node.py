"""`simbridge sim SCENE --ros2`: the sim as its own rclpy node, no endpoint process, seen
from separate rclpy processes exactly as a sim behind `simbridge endpoint --backend ros2`.

The sim and the rclpy nodes are processes of the ROS 2 venv (localhost-only DDS, this
pytest process's domain). The mobile robot's topics, services, driving and the node's
parameters are checked by tests/ros2/sim_node_checker.py; the arm's controllers by the
same rclpy ActionClient driver as tests/ros2/test_ros2_controllers.py, with the same results.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.ros2.test_ros2_controllers import ABORTED, ARM, FOLLOW, SUCCEEDED, _scene, _trajectory
from tests.ros2support import ActionDriver, Ros2Process, child_env, require_ros2

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(300)]

CHECKER = Path(__file__).parent / "sim_node_checker.py"
NODE = "simbridge_sim_test"


def _sim(scene: str | Path) -> Ros2Process:
    """`simbridge sim SCENE --ros2` in the ROS 2 venv, rendering offscreen."""
    env = {**child_env(), "MUJOCO_GL": "osmesa", "PYOPENGL_PLATFORM": "osmesa"}
    args = ["-m", "simbridge.cli", "sim", str(scene), "--ros2", "--node-name", NODE]
    return Ros2Process(args, env=env)


def _stopped(sim: Ros2Process) -> str:
    """Stop the sim (SIGINT, as Ctrl-C) and return its output."""
    sim.stop(timeout=30)
    return "".join(sim.output)


def test_the_mobile_robot_as_its_own_node() -> None:
    """joint_states, /clock, TF (and static), a camera image, odometry that follows
    /cmd_vel, robot_description, the pause and reset services, and a node parameter set
    from outside: every answer from the sim's process, which holds the only node."""
    with _sim("mobile-robot") as sim, Ros2Process([str(CHECKER), NODE]) as checker:
        seen: dict[str, Any] = {}
        while "done" not in seen:
            line = checker.expect_line(r"^\{", timeout=120)
            seen.update(json.loads(line.string))
        output = _stopped(sim)
    assert "error" not in seen, seen["error"] + "\nsim output:\n" + output[-3000:]
    assert seen["node"] == NODE
    assert "left_wheel_joint" in seen["joint_states"]
    assert seen["clock"] > 0.2
    assert {"odom->base_link", "base_link->left_wheel_link"} <= set(seen["tf"])
    assert "camera_link_optical_frame" in seen["tf_static"]
    image = seen["image"]
    assert (image["encoding"], image["frame_id"]) == ("rgb8", "camera_link_optical_frame")
    assert image["bytes"] == image["step"] * image["height"] == image["width"] * 3 * image["height"]
    assert seen["robot_description"] is True
    assert seen["odom"] == {"frame_id": "odom", "child": "base_link"}
    assert seen["moved"] > 0.05
    assert seen["pause"]["success"]
    assert seen["pause"]["message"].startswith("paused at t=")
    assert seen["resume"]["success"]
    assert seen["resume"]["message"].startswith("running at t=")
    assert seen["reset"]["after"] < seen["reset"]["before"]
    assert seen["param"] == {"set": True, "value": True}
    assert "client in-process connected" in output  # the sim's own connection, no port
    assert "listening on" not in output


@pytest.fixture
def arm_sim(tmp_path: Path) -> Iterator[Ros2Process]:
    sim = _sim(_scene(tmp_path))
    try:
        yield sim
    finally:
        sim.stop(timeout=30)


def test_controllers_from_an_rclpy_action_client(arm_sim: Ros2Process) -> None:
    """FollowJointTrajectory as through the endpoint: a goal succeeds with the joints at
    the target, an unknown joint aborts with INVALID_JOINTS (-2)."""
    driver = ActionDriver()
    try:
        driver.expect(lambda o: o.get("up") is True)
        driver.wait_ready(ARM, FOLLOW)
        driver.goal(
            "reach",
            _trajectory(["shoulder", "elbow"], [(0.5, [0.2, -0.3]), (1.0, [0.4, -0.6])]),
            action=ARM,
            kind=FOLLOW,
        )
        driver.goal(
            "joints",
            _trajectory(["shoulder", "grip_a"], [(0.2, [0.1, 0.01])]),
            action=ARM,
            kind=FOLLOW,
        )
        assert driver.reply("accepted", "reach")["ok"] is True
        reach = driver.reply("result", "reach")
        joints = driver.reply("result", "joints")
        driver.send(op="joints", topic="/arm_left/joint_states")
        positions = driver.expect(lambda o: "joints" in o)["joints"]
    finally:
        driver.proc.stop()
    assert (reach["status"], reach["values"]["error_code"]) == (SUCCEEDED, 0)
    assert (joints["status"], joints["values"]["error_code"]) == (ABORTED, -2)
    assert "grip_a" in joints["values"]["error_string"]
    assert positions["elbow"] == pytest.approx(-0.6, abs=0.01)  # the goal tolerance
    assert positions["shoulder"] == pytest.approx(0.4, abs=0.05)


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        ((), "rclpy is not importable"),
        (("--endpoint", "127.0.0.1:9"), "give --endpoint HOST:PORT or --ros2, not both"),
    ],
)
def test_without_rclpy_it_says_which_python_has_it(extra: tuple[str, ...], expected: str) -> None:
    """In an interpreter without rclpy (this one), --ros2 exits 2 naming the ROS 2 venv's
    command; with --endpoint too, it says to choose one."""
    require_ros2()
    if importlib.util.find_spec("rclpy") is not None:
        pytest.skip("rclpy is importable here")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    done = subprocess.run(
        [sys.executable, "-m", "simbridge.cli", "sim", "mobile-robot", "--ros2", *extra],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert expected in done.stderr
    if not extra:
        assert ".venv-ros2/bin/simbridge sim" in done.stderr


_PATTERN_SUBSCRIBER = """
import hashlib, json, rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image
rclpy.init()
node = rclpy.create_node("simbridge_test_pattern_subscriber")
got = []
qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
node.create_subscription(Image, "/pattern", got.append, qos)
print(json.dumps({"ready": True}), flush=True)
while len(got) < %(count)d:
    rclpy.spin_once(node, timeout_sec=0.1)
for msg in got:
    print(json.dumps({"image": [msg.width, hashlib.sha256(bytes(msg.data)).hexdigest()]}),
          flush=True)
"""

_PATTERN_PUBLISHER = """
import hashlib, json, time
from rclpy.serialization import serialize_message
from sensor_msgs.msg import Image
from simbridge.apps.ros2_node import Ros2SimNode
widths = %(widths)r
with Ros2SimNode("simbridge_test_pattern_sim") as node:
    connector = node.connector()
    pub = connector.register_publisher("/pattern", "sensor_msgs/Image", report_subscribers=True)
    deadline = time.monotonic() + 60
    while (pub.subscriber_count or 0) < 1 and time.monotonic() < deadline:
        time.sleep(0.01)
    for i, width in enumerate(widths):
        data = bytes((i + k) %% 251 for k in range(width))
        msg = Image(height=1, width=width, encoding="mono8", step=width, data=data)
        pub.publish(serialize_message(msg))  # bytes: large ones published in place
        print(json.dumps({"sent": [width, hashlib.sha256(data).hexdigest()]}), flush=True)
    connector.close()  # the drain: delivered before the node leaves
"""


def test_images_arrive_byte_for_byte_through_the_direct_publisher() -> None:
    """Serialized images of 48 KiB to 300 KiB published by the sim's own node (the larger
    ones from the bytes object's buffer, in place) reach a separate rclpy subscriber whole,
    in order, even though the publisher closes right after the last."""
    widths = [49_152, 300_000, 70_000, 120_001]
    with Ros2Process(["-c", _PATTERN_SUBSCRIBER % {"count": len(widths)}]) as subscriber:
        assert subscriber.expect_json("ready", timeout=60) is True
        with Ros2Process(["-c", _PATTERN_PUBLISHER % {"widths": widths}]) as publisher:
            sent = [publisher.expect_json("sent", timeout=60) for _ in widths]
            received = [subscriber.expect_json("image", timeout=60) for _ in widths]
    assert received == sent
    assert [width for width, _ in sent] == widths
