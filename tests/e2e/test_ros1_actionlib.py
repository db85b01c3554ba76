"""Real actionlib against the sim's controllers through the ros1 backend: Debian's
SimpleActionClient (python3-actionlib, with genpy modules for the shipped control_msgs)
sends FollowJointTrajectory goals to two namespaced copies of one arm under
`simbridge sim`, and tf2 checks the two robots' prefixed frames under one world."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from tests.ros1support import (
    SYSTEM_PYTHON,
    EndpointProcess,
    RosMaster,
    require_ros,
    terminate,
)
from tests.sim.urdf_samples import GRAVITY_ARM

from simbridge.endpoint.backends.ros1 import generate_python_messages
from simbridge.messages import default_registry

require_ros(module_level=True)

pytestmark = [pytest.mark.ros1, pytest.mark.timeout(240)]

CLIENT_NODE = r"""
import json, sys, time
import actionlib, rospy, tf2_ros
from actionlib_msgs.msg import GoalStatus
from control_msgs.msg import FollowJointTrajectoryAction, FollowJointTrajectoryGoal
from trajectory_msgs.msg import JointTrajectoryPoint

rospy.init_node("jtc_client", disable_signals=True)
out = {}

def goal(names, t, positions):
    g = FollowJointTrajectoryGoal()
    g.trajectory.joint_names = names
    g.trajectory.points = [JointTrajectoryPoint(positions=positions,
                                                time_from_start=rospy.Duration(t))]
    return g

def until_active(c):
    # the goal and the cancel (or a second client's goal) travel on different topics:
    # send the next only once the server took the goal, not after a guessed delay
    deadline = time.time() + 60
    while c.get_state() != GoalStatus.ACTIVE and time.time() < deadline:
        time.sleep(0.02)

def client():
    c = actionlib.SimpleActionClient(
        "/arm_left/arm_controller/follow_joint_trajectory", FollowJointTrajectoryAction)
    out.setdefault("server", []).append(c.wait_for_server(rospy.Duration(60)))
    return c

left = client()
left.send_goal(goal(["shoulder", "elbow"], 0.5, [0.3, -0.4]))
left.wait_for_result(rospy.Duration(30))
out["success"] = [left.get_state(), left.get_result().error_code]

left.send_goal(goal(["elbow"], 5.0, [1.2]))
until_active(left)
left.cancel_goal()
left.wait_for_result(rospy.Duration(30))
out["cancel"] = [left.get_state(), left.get_result().error_code]

other = client()
left.send_goal(goal(["elbow"], 5.0, [1.2]))
until_active(left)
other.send_goal(goal(["elbow"], 0.3, [0.1]))
left.wait_for_result(rospy.Duration(30))
other.wait_for_result(rospy.Duration(30))
out["preempted"] = [left.get_state(), other.get_state()]

left.send_goal(goal(["shoulder", "knee"], 0.5, [0.0, 0.0]))
left.wait_for_result(rospy.Duration(30))
out["rejected"] = [left.get_state(), left.get_result().error_code,
                   left.get_result().error_string]

right = actionlib.SimpleActionClient(
    "/arm_right/arm_controller/follow_joint_trajectory", FollowJointTrajectoryAction)
right.wait_for_server(rospy.Duration(30))
right.send_goal(goal(["shoulder"], 0.3, [-0.5]))
right.wait_for_result(rospy.Duration(30))
out["right"] = [right.get_state(), right.get_result().error_code]

buffer = tf2_ros.Buffer()
listener = tf2_ros.TransformListener(buffer)
frames = {}
for frame in ("arm_left/finger_a", "arm_right/finger_a", "arm_right/base"):
    t = buffer.lookup_transform("world", frame, rospy.Time(0), rospy.Duration(20))
    frames[frame] = [t.transform.translation.x, t.transform.translation.y,
                     t.transform.translation.z]
out["frames"] = frames
print(json.dumps(out))
"""


def _scene(tmp_path: Path) -> Path:
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    controllers = {
        "arm_controller": {
            "type": "joint_trajectory_controller",
            "joints": ["shoulder", "elbow", "wrist"],
        }
    }
    robots = [
        {"urdf": "arm.urdf", "base": {"xyz": [0, y, 0]},
         "ros": {"namespace": f"/arm_{side}", "frame_prefix": f"arm_{side}/",
                 "controllers": controllers}}
        for side, y in (("left", 0.5), ("right", -0.5))
    ]  # fmt: skip
    scene = {"physics": {"gravity": [0, 0, 0]}, "robots": robots}
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    return tmp_path / "scene.yaml"


def test_simple_action_client_drives_the_namespaced_controllers(tmp_path: Path) -> None:
    probe = subprocess.run(
        [SYSTEM_PYTHON, "-c", "import actionlib, tf2_ros"], check=False, capture_output=True
    )
    if probe.returncode != 0:
        message = "python3-actionlib / python3-tf2-ros are not installed (make sysdeps)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    scene = _scene(tmp_path)
    extra = generate_python_messages(
        default_registry(), [], tmp_path / "ws", ["control_msgs/FollowJointTrajectoryAction"]
    )
    with RosMaster() as master:
        env = dict(master.env)
        for key, value in extra.items():
            env[key] = os.pathsep.join(v for v in (value, env.get(key, "")) if v)
        endpoint = EndpointProcess(master, "/jtc_endpoint")
        port = endpoint.port
        sim_command = [sys.executable, "-m", "simbridge.cli", "sim", str(scene)]
        sim_command += ["--endpoint", f"127.0.0.1:{port}", "--duration", "120"]
        client = subprocess.Popen(
            [SYSTEM_PYTHON, "-c", CLIENT_NODE], env=env, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, text=True, start_new_session=True,
        )  # fmt: skip
        try:
            with master.running(sim_command):
                out, err = client.communicate(timeout=180)
        finally:
            terminate(client)
            endpoint.stop()
    assert client.returncode == 0, err[-3000:]
    result = json.loads(out.strip().splitlines()[-1])
    assert all(result["server"]), result
    assert result["success"] == [3, 0], result  # SUCCEEDED, SUCCESSFUL
    assert result["cancel"] == [2, 0], result  # PREEMPTED
    assert result["preempted"] == [2, 3], result  # the old goal PREEMPTED, the new SUCCEEDED
    assert result["rejected"][:2] == [5, -2], result  # REJECTED, INVALID_JOINTS
    assert "knee" in result["rejected"][2]
    assert result["right"] == [3, 0], result
    frames = result["frames"]
    assert frames["arm_right/base"] == pytest.approx([0.0, -0.5, 0.0], abs=1e-6)
    assert frames["arm_left/finger_a"][1] > 0.3  # each arm's fingers near its own base
    assert frames["arm_right/finger_a"][1] < -0.3
