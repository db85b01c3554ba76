"""The ROS 1 graph as ROS tools see it, through `simbridge endpoint --backend ros1` subprocesses.

Each test that may disturb the graph (name collisions, signals) starts its own
endpoint process on the module's private roscore.
"""

from __future__ import annotations

import logging
import signal
import sys
import textwrap
from pathlib import Path

import pytest
from tests.ros1support import (
    FAST,
    SYSTEM_PYTHON,
    EndpointProcess,
    RosMaster,
    require_ros,
    wait_until,
)

from simbridge.connector import Connector

require_ros(module_level=True)

import rosgraph  # noqa: E402

pytestmark = [pytest.mark.ros1, pytest.mark.timeout(180)]


def system_state(master: RosMaster) -> list[list[tuple[str, list[str]]]]:
    state: list[list[tuple[str, list[str]]]] = rosgraph.Master(
        "/e2e_graph_test", master_uri=master.uri
    ).getSystemState()
    return state


def node_registrations(master: RosMaster, node: str) -> list[str]:
    """Every topic or service `node` is registered for, as `kind:name`."""
    kinds = ("pub", "sub", "srv")
    return [
        f"{kind}:{name}"
        for kind, entries in zip(kinds, system_state(master), strict=True)
        for name, nodes in entries
        if node in nodes
    ]


def test_simbridge_topic_list_matches_rostopic_list(master: RosMaster, tmp_path: Path) -> None:
    """`simbridge topic list` shows what is published or subscribed now, as `rostopic list`
    does, not every topic the master ever saw (here: those of a node that exited)."""
    script = tmp_path / "ephemeral.py"
    script.write_text(
        textwrap.dedent(
            """
            import rospy
            from std_msgs.msg import String

            rospy.init_node("e2e_ephemeral")
            rospy.Publisher("/e2e/ephemeral", String, queue_size=1)
            rospy.sleep(0.5)
            """
        )
    )
    endpoint = EndpointProcess(master, "/e2e_topic_list")
    try:
        done = master.run([SYSTEM_PYTHON, str(script)])
        assert done.returncode == 0, done.stderr
        remembered = rosgraph.Master("/t", master_uri=master.uri).getTopicTypes()
        assert ["/e2e/ephemeral", "std_msgs/String"] in remembered  # the master never forgets
        with Connector("127.0.0.1", endpoint.port, FAST).connect(wait=10) as conn:
            conn.register_publisher("/e2e/live", "std_msgs/String")
            wait_until(lambda: "/e2e/live" in conn.topic_list(), 10, "/e2e/live in the list")
            listed = conn.topic_list()
            address = f"127.0.0.1:{endpoint.port}"
            cli = [sys.executable, "-m", "simbridge.cli"]
            tool = master.run([*cli, "topic", "list", "-v", "--endpoint", address])
            rostopic = master.run(["rostopic", "list"])
        assert tool.returncode == 0, tool.stderr
        assert rostopic.returncode == 0, rostopic.stderr
        assert "/e2e/ephemeral" not in listed
        assert set(listed) == set(rostopic.stdout.split())
        shown = dict(line.split() for line in tool.stdout.splitlines())
        assert shown == listed
        assert shown["/e2e/live"] == "std_msgs/String"
    finally:
        endpoint.stop()


def test_sigterm_unregisters_everything(master: RosMaster) -> None:
    """kill (SIGTERM) withdraws the clients' topics and services and the node itself."""
    endpoint = EndpointProcess(master, "/e2e_sigterm")
    try:
        with Connector("127.0.0.1", endpoint.port, FAST).connect(wait=10) as conn:
            conn.register_publisher("/e2e/term_pub", "std_msgs/String")
            conn.subscribe("/e2e/term_sub", "std_msgs/String", lambda _: None, raw=True)
            conn.implement_service("/e2e/term_srv", "std_srvs/Trigger", lambda _: b"", raw=True)
            expected = {"pub:/e2e/term_pub", "sub:/e2e/term_sub", "srv:/e2e/term_srv"}
            wait_until(
                lambda: expected <= set(node_registrations(master, "/e2e_sigterm")),
                10,
                "the registrations",
            )
            endpoint.process.send_signal(signal.SIGTERM)
            assert endpoint.process.wait(20) == 0, endpoint.output()
    finally:
        endpoint.stop()
    assert node_registrations(master, "/e2e_sigterm") == []  # /rosout's publisher too


def test_endpoint_replaced_by_same_name_tells_clients_and_exits(
    master: RosMaster, caplog: pytest.LogCaptureFixture
) -> None:
    """The master shuts a node down when another registers its name: the endpoint must
    not stay up as if its clients still reached ROS."""
    first = EndpointProcess(master, "/e2e_twin")
    second: EndpointProcess | None = None
    try:
        with (
            caplog.at_level(logging.ERROR, logger="simbridge.connector"),
            Connector("127.0.0.1", first.port, FAST).connect(wait=10) as conn,
        ):
            conn.register_publisher("/e2e/twin_pub", "std_msgs/String")
            wait_until(
                lambda: "pub:/e2e/twin_pub" in node_registrations(master, "/e2e_twin"),
                10,
                "the publisher",
            )
            second = EndpointProcess(master, "/e2e_twin")
            assert first.process.wait(20) == 2, first.output()
            wait_until(
                lambda: any("was shut down" in r.getMessage() for r in caplog.records),
                10,
                "the __error at the client",
            )
        told = [r.getMessage() for r in caplog.records if "was shut down" in r.getMessage()]
        assert "/e2e_twin" in told[0]
        assert "new node registered with same name" in told[0]
        assert "simbridge: error: the ROS node /e2e_twin was shut down" in first.output()
        assert second.process.poll() is None, first.output() + "\n=====\n" + second.output()
        assert "pub:/e2e/twin_pub" not in node_registrations(master, "/e2e_twin")
    finally:
        first.stop()
        if second is not None:
            second.stop()
