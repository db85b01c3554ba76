"""simbridge's Fast DDS profile: Fast DDS parses all of it and applies its writer settings."""

from __future__ import annotations

import re
import textwrap

import pytest
from tests.ros2support import Ros2Process

from simbridge.endpoint.backends.ros2.env import WRITER_ALLOCATED_SAMPLES

pytestmark = [pytest.mark.ros2, pytest.mark.timeout(120)]

_SCRIPT = textwrap.dedent(
    """
    import json, rclpy
    from geometry_msgs.msg import Twist
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    def rss():
        return int(open("/proc/self/statm").read().split()[1]) * 4096

    def publisher(depth):
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                         reliability=ReliabilityPolicy.RELIABLE)
        before = rss()
        node.create_publisher(Twist, f"/sb_profile_{depth}", qos)
        return rss() - before

    rclpy.init()
    node = rclpy.create_node("sb_profile")
    publisher(10)  # the first publisher's one-off allocations
    shallow, deep = publisher(10), publisher(DEEP)
    print(json.dumps({"sizes": {"shallow": shallow, "deep": deep}}), flush=True)
    node.destroy_node()
    rclpy.shutdown()
    """
)


def test_profile_parses_and_deep_publishers_reserve_their_samples() -> None:
    """No XMLPARSER error, and a publisher as deep as WRITER_ALLOCATED_SAMPLES reserves
    room for them when created (Fast DDS's default of 100 would add next to nothing)."""
    proc = Ros2Process(["-c", _SCRIPT.replace("DEEP", str(WRITER_ALLOCATED_SAMPLES))])
    try:
        result = proc.expect_json("sizes", timeout=60)
        output = "".join(proc.output)  # Fast DDS reports profile errors at rclpy.init()
    finally:
        proc.stop()
    assert "XMLPARSER" not in output, output
    # Fast DDS numbers every participant's shared-memory port from 7000 up, machine-wide
    # (whatever the domain): while another participant holds one, it logs an Error for it
    # and takes the next. That says something about the machine, not about the profile.
    port_taken = re.compile(r"Failed init_port fastrtps_port\d+: open_and_lock_file failed")
    errors = [line for line in output.splitlines() if "Error" in line]
    assert [line for line in errors if not port_taken.search(line)] == [], output
    per_sample = (result["deep"] - result["shallow"]) / WRITER_ALLOCATED_SAMPLES
    assert per_sample > 64, f"{result}: the deep publisher reserved nothing per sample"
