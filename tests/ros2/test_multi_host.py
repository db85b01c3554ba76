"""Two sims on two "hosts", one ROS 2 graph: the recipe of docs/ros2.md (Several hosts
on one ROS 2 graph), on simulated hosts.

multi_host_driver.py runs in a private network namespace (`unshare -rn`) and makes
each host a network namespace of its own on a bridge in it (10.213.7.0/24, no
multicast route): hosts a and b run `simbridge sim` + a ros2 endpoint for /robot_a
resp. /robot_b, host c an rclpy checker; all use the peers-only Fast DDS profile
(fastdds_peers_profile_xml). The control, host d, lists only itself as peer and must
find neither robot. Nothing reaches the machine's real interfaces; the namespaces go
when the driver exits.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.ros2support import require_ros2

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(240)]

ROOT = Path(__file__).resolve().parents[2]
TOPICS = ("/robot_a/joint_states", "/robot_b/joint_states")


def test_two_sims_on_two_hosts_share_one_graph() -> None:
    require_ros2()
    for tool in ("unshare", "nsenter", "ip"):
        if shutil.which(tool) is None:
            pytest.skip(f"{tool} (util-linux, iproute2) is needed to simulate hosts")
    probe = subprocess.run(
        ["unshare", "-rn", "ip", "link", "add", "br0", "type", "bridge"],
        capture_output=True,
        text=True,
        check=False,
    )
    if probe.returncode != 0:
        pytest.skip(
            "cannot create a network namespace with a bridge here (needs root or user "
            f"namespaces): {probe.stderr.strip()}"
        )
    out = subprocess.run(
        ["unshare", "-rn", sys.executable, "-m", "tests.ros2.multi_host_driver"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=200,
        check=False,
    )
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-4000:]
    result = json.loads(out.stdout.strip().splitlines()[-1])
    seen, control, packets = result["seen"], result["control"], result["packets"]
    joints = ["shoulder", "elbow", "wrist", "grip_a", "grip_b"]
    for topic in TOPICS:
        assert seen[topic]["types"] == ["sensor_msgs/msg/JointState"], seen
        assert seen[topic]["publishers"] == 1, seen  # one sim per robot, on its own host
        assert seen[topic]["joints"] == joints, seen
        assert control[topic]["publishers"] == 0, control  # not a peer: found nothing
        assert control[topic]["joints"] is None, control
    for host in ("a", "b", "c"):  # the graph's traffic crossed each host's link
        received, sent = packets[host]
        assert received > 0, packets
        assert sent > 0, packets
