"""Nothing accepted is lost on ROS 1: a client that publishes N Twists through
`simbridge endpoint --backend ros1` and leaves at once has all N delivered to a rospy
subscriber (what the endpoint's TCPROS connection still queued or held for it is sent
before the topic closes), in order."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest
from tests.endpoint.drainclient import publish_and_close
from tests.ros1support import SYSTEM_PYTHON, EndpointProcess, RosMaster, wait_until

pytestmark = [pytest.mark.ros1, pytest.mark.timeout(300)]

COUNT = 200_000
"""Twists sent: 10 MB, more than the kernel's socket buffers and the endpoint's write
high-water mark take, so the endpoint holds some for the subscriber, which reads nothing
until the client has left."""

_SUBSCRIBER = textwrap.dedent(
    """
    import json, os, sys, time
    import rospy
    from geometry_msgs.msg import Twist

    expected, go = int(sys.argv[1]), sys.argv[2]
    state = {"count": 0, "in_order": True}
    last = [time.monotonic()]

    def received(msg):
        while not os.path.exists(go):  # blocks rospy's reading of the connection
            time.sleep(0.01)
        if msg.linear.x != state["count"]:
            state["in_order"] = False
        state["count"] += 1
        last[0] = time.monotonic()

    rospy.init_node("drain_counter", disable_signals=True)
    rospy.Subscriber("/drain/ros1", Twist, received, queue_size=None)
    print(json.dumps({"ready": True}), flush=True)
    while state["count"] < expected and time.monotonic() - last[0] < 60:
        time.sleep(0.05)
    print(json.dumps(state), flush=True)
    """
)


def test_publish_then_close_delivers_everything(master: RosMaster, tmp_path: Path) -> None:
    script = tmp_path / "drain_counter.py"
    script.write_text(_SUBSCRIBER)
    endpoint = EndpointProcess(master, "/drain_endpoint", "--drain-timeout", "120")
    try:
        go = tmp_path / "go"
        with master.running([SYSTEM_PYTHON, str(script), str(COUNT), str(go)]) as counter:
            wait_until(lambda: '"ready"' in counter.output()[0], 60, "the rospy subscriber")
            sent = publish_and_close(
                endpoint.port, "/drain/ros1", COUNT, COUNT, cdr=False, stats=True
            )
            go.touch()
            wait_until(lambda: '"count"' in counter.output()[0], 240, "the count")
            line = next(x for x in counter.output()[0].splitlines() if '"count"' in x)
    finally:
        endpoint.stop()
    assert json.loads(line) == {"count": COUNT, "in_order": True}
    assert sent.stats["session"]["published"] == {"/drain/ros1": COUNT}
