"""`simbridge planner` on its own: ROS 1 node lifecycle (signals, name collisions) and local mode.

The ROS 1 calls themselves (rosservice call, a rospy client) are in test_pick_and_place_ros1,
whose planner fixture runs this command.
"""

from __future__ import annotations

import json
import re
import signal
import socket
import subprocess
import sys
import time
import xmlrpc.client
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml

from simbridge.apps.pick_and_place import PLANNER_SERVICE, PickAndPlaceTask
from simbridge.errors import EndpointError
from simbridge.planning import Pose
from tests.ros1support import RosMaster, require_ros, terminate

pytestmark = [pytest.mark.timeout(420)]

PLANNER = [sys.executable, "-m", "simbridge.cli", "planner"]


def wait_for(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.1)


@pytest.fixture(scope="module")
def master() -> Iterator[RosMaster]:
    require_ros()
    with RosMaster() as master:
        yield master


def served_by(master: RosMaster) -> str | None:
    """The node answering a probe on /niryo_moveit, or None."""
    from simbridge.endpoint.backends.ros1 import probe_service

    try:
        return probe_service(master.uri, PLANNER_SERVICE)
    except EndpointError:
        return None


def node_entries(master: RosMaster, node: str) -> list[str]:
    """Every topic and service `node` is registered for."""
    reply: Any = xmlrpc.client.ServerProxy(master.uri).getSystemState("/test_planner_cli")
    return [name for kind in reply[2] for name, nodes in kind if node in nodes]


def start_planner(master: RosMaster, node: str) -> subprocess.Popen[str]:
    process = master.spawn([*PLANNER, "--backend", "ros1", "--node-name", node])
    wait_for(  # generous: the planner imports MuJoCo and builds its scene first
        lambda: process.poll() is not None or served_by(master) == f"/{node}",
        180,
        f"/{node} to serve {PLANNER_SERVICE}",
    )
    assert process.poll() is None, process.communicate()
    return process


@pytest.mark.ros1
def test_sigterm_unregisters_the_planner(master: RosMaster) -> None:
    planner = start_planner(master, "planner_sigterm")
    try:
        assert node_entries(master, "/planner_sigterm")  # /niryo_moveit, /rosout
        planner.send_signal(signal.SIGTERM)
        assert planner.wait(60) == 0, planner.communicate()
    finally:
        terminate(planner)
    assert node_entries(master, "/planner_sigterm") == []
    reply: Any = xmlrpc.client.ServerProxy(master.uri).lookupService("/t", PLANNER_SERVICE)
    assert reply[0] != 1


@pytest.mark.ros1
def test_planner_replaced_by_same_name_exits_non_zero(master: RosMaster) -> None:
    first = start_planner(master, "planner_twin")
    second: subprocess.Popen[str] | None = None
    try:
        second = start_planner(master, "planner_twin")
        out, err = first.communicate(timeout=20)
        assert first.returncode == 2, out + err  # the CLI's exit status for errors
        assert "/planner_twin was shut down" in err
        assert "new node registered with same name" in err
        assert served_by(master) == "/planner_twin"  # the newcomer serves
        assert second.poll() is None
    finally:
        terminate(first)
        if second is not None:
            terminate(second)


def test_local_planner_answers_simbridge_service_call() -> None:
    """`--backend local`: an endpoint with the planner on its bus; no ROS needed."""
    planner = subprocess.Popen(
        [*PLANNER, "--backend", "local", "--port", "0"],  # the OS chooses; read back
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        stdin=subprocess.DEVNULL,
        text=True,
        start_new_session=True,
    )
    try:
        assert planner.stdout is not None
        line = planner.stdout.readline()  # (logs go to stderr)
        assert f"serving {PLANNER_SERVICE} [niryo_moveit/MoverService]" in line, line
        found = re.search(r"127\.0\.0\.1:(\d+)", line)
        assert found is not None, line
        port = int(found.group(1))
        assert port != 0
        task = PickAndPlaceTask()

        def pose(p: Pose) -> dict[str, Any]:
            x, y, z = (float(v) for v in p.position)
            qx, qy, qz, qw = (float(v) for v in p.orientation)
            return {"position": {"x": x, "y": y, "z": z},
                    "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}}  # fmt: skip

        request = {
            "joints_input": {"joints": [0.0] * 6},
            "pick_pose": pose(task.pick_pose(0.05)),
            "place_pose": pose(task.place_pose(0.05)),
        }
        service = [PLANNER_SERVICE, "niryo_moveit/MoverService", json.dumps(request)]
        where = ["--endpoint", f"127.0.0.1:{port}", "--timeout", "60"]
        call = subprocess.run(
            [sys.executable, "-m", "simbridge.cli", "service", "call", *service, *where],
            capture_output=True,
            text=True,
            timeout=90,
            check=False,
        )
        assert call.returncode == 0, call.stderr
        response = yaml.safe_load(call.stdout.split("---")[0])
        assert len(response["trajectories"]) == 4
        names = response["trajectories"][0]["joint_trajectory"]["joint_names"]
        assert names == [f"joint_{i}" for i in range(1, 7)]
        planner.send_signal(signal.SIGTERM)
        assert planner.wait(20) == 0
    finally:
        terminate(planner)


@pytest.mark.ros1
def test_demo_waits_for_its_own_planner_not_a_stale_registration(
    master: RosMaster,
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    request: pytest.FixtureRequest,
) -> None:
    """A planner that died without unregistering left /niryo_moveit pointing at a closed
    port: the demo's readiness check must not take that for its planner."""
    from simbridge.apps.pick_and_place.ros1_graph import Ros1Graph

    held = socket.socket()  # bound, never listening: a closed port no one can take meanwhile
    held.bind(("127.0.0.1", 0))
    request.addfinalizer(held.close)
    dead = held.getsockname()[1]
    api = xmlrpc.client.ServerProxy(master.uri)
    reply: Any = api.registerService(
        "/dead_planner", PLANNER_SERVICE, f"rosrpc://127.0.0.1:{dead}", f"http://127.0.0.1:{dead}/"
    )
    assert reply[0] == 1
    assert served_by(master) is None  # registered, but nobody answers
    monkeypatch.setenv("ROS_MASTER_URI", master.uri)
    monkeypatch.setenv("ROS_HOSTNAME", "127.0.0.1")
    monkeypatch.setenv("ROS_HOME", str(tmp_path))
    with Ros1Graph() as graph:
        assert not graph.master.started
        assert graph.planner_node.startswith("/niryo_moveit_planner_")
        assert served_by(master) == graph.planner_node  # ready means: it answers now
    assert node_entries(master, graph.planner_node) == []
