"""The ROS 1 backend reports the graph as ROS tools see it now, not as the master remembers it."""

from __future__ import annotations

import asyncio
import struct
import subprocess
import textwrap
import xmlrpc.client
from pathlib import Path
from typing import Any

import pytest
from tests.ros1support import SYSTEM_PYTHON, RosMaster, require_ros, with_backend

from simbridge.endpoint.backends.base import TopicInfo

require_ros(module_level=True)

import rospy  # noqa: E402

from simbridge.endpoint.backends.ros1 import Ros1Backend  # noqa: E402
from simbridge.endpoint.backends.ros1.rejoin import register_again  # noqa: E402

pytestmark = [
    pytest.mark.ros1,
    pytest.mark.timeout(120),
    pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning"),
]


def rostopic_list(master: RosMaster) -> set[str]:
    result = master.run(["rostopic", "list"])
    assert result.returncode == 0, result.stderr
    return set(result.stdout.split())


def test_topic_list_forgets_topics_of_a_node_that_exited(master: RosMaster, tmp_path: Path) -> None:
    """A node publishes /sb/ephemeral and exits: the master still has its type, but
    the topic list (like `rostopic list`) no longer shows it."""
    script = tmp_path / "ephemeral_node.py"
    script.write_text(
        textwrap.dedent(
            """
            import sys, rospy
            from std_msgs.msg import String

            rospy.init_node("sb_ephemeral_talker")
            pub = rospy.Publisher("/sb/ephemeral", String, queue_size=1)
            sub = rospy.Subscriber("/sb/ephemeral_listened", String, lambda m: None)
            print("up", flush=True)
            sys.stdin.readline()  # runs until the test closes stdin, then exits cleanly
            """
        )
    )

    async def scenario(backend: Ros1Backend) -> tuple[list[TopicInfo], list[TopicInfo]]:
        backend.advertise("/sb/staying", "std_msgs/String", queue_size=1, latch=False)
        node = subprocess.Popen(
            [SYSTEM_PYTHON, str(script)],
            env=master.env,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        try:
            assert node.stdout is not None
            assert node.stdin is not None
            assert await asyncio.to_thread(node.stdout.readline) == "up\n"
            during = backend.topics()
            node.stdin.close()
            assert await asyncio.to_thread(node.wait, 30) == 0
        finally:
            if node.poll() is None:
                node.kill()
                node.wait()
        after = backend.topics()
        assert {t.name for t in after} == await asyncio.to_thread(rostopic_list, master)
        return during, after

    during, after = with_backend(scenario)
    assert TopicInfo("/sb/ephemeral", "std_msgs/String") in during
    assert TopicInfo("/sb/ephemeral_listened", "std_msgs/String") in during  # subscribed only
    names_after = {t.name for t in after}
    assert "/sb/ephemeral" not in names_after
    assert "/sb/ephemeral_listened" not in names_after
    assert "/sb/staying" in names_after
    assert TopicInfo("/rosout", "rosgraph_msgs/Log") in after
    assert after == sorted(after, key=lambda t: t.name)


def test_register_again_restores_what_a_new_master_lacks(master: RosMaster) -> None:
    """What a restarted master looks like to a node: none of its registrations.
    register_again (what MasterWatch runs then) gives it every one back; the restart
    itself (kill -9 of roscore) is tested in tests/e2e/test_ros1_master_restart.py."""
    api: Any = xmlrpc.client.ServerProxy(master.uri)

    def ours() -> set[str]:
        _, _, state = api.getSystemState("/sb_test")
        return {
            f"{kind}:{name}"
            for kind, entries in zip(("pub", "sub", "srv"), state, strict=True)
            for name, nodes in entries
            if rospy.get_name() in nodes
        }

    async def handler(request: bytes) -> bytes:
        return b"\x01" + struct.pack("<I", 0)

    async def scenario(backend: Ros1Backend) -> tuple[int, int, int]:
        backend.advertise("/sb/forgotten_pub", "std_msgs/String", queue_size=1, latch=False)
        backend.subscribe("/sb/forgotten_sub", "std_msgs/String", lambda _: None)
        backend.advertise_service("/sb/forgotten_srv", "std_srvs/SetBool", handler)
        held = ours()
        assert {"pub:/sb/forgotten_pub", "sub:/sb/forgotten_sub", "srv:/sb/forgotten_srv"} <= held
        node, node_uri = rospy.get_name(), rospy.core.get_node_uri()
        for entry in held:  # the master forgets this node entirely
            kind, name = entry.split(":", 1)
            if kind == "pub":
                api.unregisterPublisher(node, name, node_uri)
            elif kind == "sub":
                api.unregisterSubscriber(node, name, node_uri)
            else:
                (_, _, uri) = api.lookupService(node, name)
                api.unregisterService(node, name, uri)
        assert ours() == set()  # as a new master would have it
        counts = register_again(master.uri)
        assert ours() == held
        return counts

    published, subscribed, served = with_backend(scenario)
    assert published >= 2  # /sb/forgotten_pub and rospy's /rosout
    assert subscribed >= 1
    assert served >= 1
