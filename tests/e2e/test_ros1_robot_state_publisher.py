"""The sim's /tf agrees with the real robot_state_publisher fed the sim's /joint_states.

A swinging arm runs under `simbridge sim` through `simbridge endpoint --backend ros1`.
robot_state_publisher (Debian's, with the same URDF) turns the sim's /joint_states into
TF on /rsp/tf; a rospy node holds two tf2 buffers, one fed the sim's /tf and
/tf_static, one fed RSP's, and looks up every link at every stamp RSP published. Before
the fix TF lagged joint states by one physics step and the two disagreed by millimetres
(issue 11.1).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import xmlrpc.client
from pathlib import Path

import pytest
import yaml
from tests.ros1support import (
    SYSTEM_PYTHON,
    EndpointProcess,
    RosMaster,
    require_ros,
)
from tests.sim.urdf_samples import GRAVITY_ARM

require_ros(module_level=True)

pytestmark = [pytest.mark.ros1, pytest.mark.timeout(240)]

COMPARE_NODE = r"""
import json, math, sys, time
import rospy, tf2_ros
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage

wanted = int(sys.argv[1])
rospy.init_node("tf_compare", disable_signals=True)
sim = tf2_ros.Buffer(cache_time=rospy.Duration(600))
rsp = tf2_ros.Buffer(cache_time=rospy.Duration(600))
stamps, links, moving = set(), set(), []

def feed(buffer, static):
    def callback(msg):
        for t in msg.transforms:
            if static:
                buffer.set_transform_static(t, "test")
            else:
                buffer.set_transform(t, "test")
            if buffer is rsp and not static:
                stamps.add(t.header.stamp)
                links.add(t.child_frame_id)
    return callback

rospy.Subscriber("/tf", TFMessage, feed(sim, False), queue_size=1000)
rospy.Subscriber("/tf_static", TFMessage, feed(sim, True), queue_size=10)
rospy.Subscriber("/rsp/tf", TFMessage, feed(rsp, False), queue_size=1000)
rospy.Subscriber("/rsp/tf_static", TFMessage, feed(rsp, True), queue_size=10)
rospy.Subscriber("/joint_states", JointState,
                 lambda m: moving.append(max(abs(v) for v in m.velocity) > 0.5), queue_size=1000)
deadline = time.monotonic() + 90
while len(stamps) < wanted and time.monotonic() < deadline:
    time.sleep(0.05)
time.sleep(0.5)  # the sim's /tf for the last stamps
worst_xyz = worst_rot = 0.0
compared = 0
for stamp in sorted(stamps)[:-2]:
    for link in sorted(links):
        try:
            a = sim.lookup_transform("base", link, stamp).transform
            b = rsp.lookup_transform("base", link, stamp).transform
        except tf2_ros.TransformException:
            continue
        ta, tb = a.translation, b.translation
        worst_xyz = max(worst_xyz, abs(ta.x - tb.x), abs(ta.y - tb.y), abs(ta.z - tb.z))
        qa, qb = a.rotation, b.rotation
        sign = math.copysign(1.0, qa.x * qb.x + qa.y * qb.y + qa.z * qb.z + qa.w * qb.w)
        pairs = ((qa.x, qb.x), (qa.y, qb.y), (qa.z, qb.z), (qa.w, qb.w))
        worst_rot = max(worst_rot, *(abs(p - sign * q) for p, q in pairs))
        compared += 1
print(json.dumps({"stamps": len(stamps), "compared": compared, "links": sorted(links),
                  "moving": sum(moving), "xyz": worst_xyz, "rot": worst_rot}))
"""


def _require_rsp() -> str:
    rosrun = shutil.which("rosrun")
    probe = subprocess.run(
        [SYSTEM_PYTHON, "-c", "import tf2_ros"], check=False, capture_output=True
    )
    found = rosrun and Path("/usr/lib/robot_state_publisher/robot_state_publisher").exists()
    if found and probe.returncode == 0:
        return str(rosrun)
    message = "robot_state_publisher and python3-tf2-ros are not installed (make sysdeps)"
    if os.environ.get("CI"):
        pytest.fail(message)
    pytest.skip(message)


def test_sim_tf_matches_robot_state_publisher(tmp_path: Path) -> None:
    rosrun = _require_rsp()
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    scene = {
        "robots": [{
            "urdf": "arm.urdf",
            "initial_positions": {"shoulder": -1.2, "elbow": 1.0},
            # passive joints: the arm swings under gravity for the whole run
            "drives": {"default": {"mode": "none"}},
        }],
        "ros": {"joint_states_rate": 50, "tf_rate": 50},
    }  # fmt: skip
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    with RosMaster() as master:
        xmlrpc.client.ServerProxy(master.uri).setParam("/test", "/robot_description", GRAVITY_ARM)
        endpoint = EndpointProcess(master, "/rsp_test_endpoint")
        port = endpoint.port
        rsp_command = [rosrun, "robot_state_publisher", "robot_state_publisher"]
        rsp_command += ["tf:=/rsp/tf", "tf_static:=/rsp/tf_static", "_publish_frequency:=1000"]
        compare_command = [SYSTEM_PYTHON, "-c", COMPARE_NODE, "100"]
        sim_command = [sys.executable, "-m", "simbridge.cli", "sim", str(tmp_path / "scene.yaml")]
        sim_command += ["--endpoint", f"127.0.0.1:{port}", "--duration", "30"]
        try:
            with (
                master.running(rsp_command),
                master.running(compare_command) as compare,
                master.running(sim_command),
            ):
                out, err = compare.communicate(timeout=150)
        finally:
            endpoint.stop()
    assert compare.returncode == 0, err
    result = json.loads(out.strip().splitlines()[-1])
    assert result["links"] == ["finger_a", "finger_b", "fore", "spin", "upper"], result
    assert result["compared"] >= 5 * 90, result
    assert result["moving"] >= 50, result
    assert result["xyz"] < 1e-9, result
    assert result["rot"] < 1e-9, result  # quaternion components
