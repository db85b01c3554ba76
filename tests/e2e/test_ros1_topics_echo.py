"""Every topic the sim publishes through `simbridge endpoint --backend ros1` can be read
with the real `rostopic echo -n 1`, and every topic it subscribes can be written and
echoed with the ROS tools: the Debian message packages (make sysdeps) cover every type.

The scene is the mobile-robot demo's (lidar, compressed camera, IMU, odometry, joint
states, TF, clock, /cmd_vel) with the arm command topics (/joint_trajectory, group
position and velocity commands) switched on as a scene without a `commands` key has them.
"""

from __future__ import annotations

import subprocess
import sys
import time
import xmlrpc.client
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import pytest
import yaml
from tests.ros1support import EndpointProcess, RosMaster, require_ros, terminate

from simbridge.apps.mobile_robot import SCENE_PATH

require_ros(module_level=True)

pytestmark = [pytest.mark.ros1, pytest.mark.timeout(240)]

NODE = "/simbridge_echo_test_endpoint"
SIM_PUBLISHES = {"/joint_states", "/tf", "/tf_static", "/clock", "/scan", "/imu", "/odom"}
SIM_SUBSCRIBES = {
    "/cmd_vel",
    "/joint_trajectory",
    "/joint_group_position_controller/command",
    "/joint_group_velocity_controller/command",
}


def _scene(tmp_path: Path) -> Path:
    """The mobile-robot demo's scene, with absolute paths and the default command topics."""
    source = Path(SCENE_PATH)
    data: dict[str, Any] = yaml.safe_load(source.read_text())
    for robot in data["robots"]:
        robot["urdf"] = str((source.parent / robot["urdf"]).resolve())
    del data["ros"]["commands"]
    scene = tmp_path / "scene.yaml"
    scene.write_text(yaml.safe_dump(data))
    return scene


@pytest.fixture(scope="module")
def graph(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RosMaster]:
    """roscore, the ros1 endpoint and `simbridge sim` on the demo scene, paced at real time."""
    require_ros()
    scene = _scene(tmp_path_factory.mktemp("scene"))
    with RosMaster() as master:
        endpoint = EndpointProcess(master, NODE)
        port = endpoint.port
        sim_command = [sys.executable, "-m", "simbridge.cli", "sim", str(scene)]
        sim_command += ["--endpoint", f"127.0.0.1:{port}", "--duration", "600", "--realtime", "1"]
        try:
            with master.running(sim_command) as sim:
                _wait_for_topics(master, sim)
                yield master
        finally:
            endpoint.stop()


def _master_call(master: RosMaster, method: str) -> Any:
    reply: Any = getattr(xmlrpc.client.ServerProxy(master.uri), method)("/echo_test")
    code, message, value = reply
    assert code == 1, message
    return value


def _state(master: RosMaster) -> tuple[set[str], set[str]]:
    """Topics the endpoint node publishes, and those it subscribes."""
    pubs, subs, _ = _master_call(master, "getSystemState")
    return {t for t, nodes in pubs if NODE in nodes}, {t for t, nodes in subs if NODE in nodes}


def _wait_for_topics(master: RosMaster, sim: subprocess.Popen[str]) -> None:
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        published, subscribed = _state(master)
        if published >= SIM_PUBLISHES and subscribed >= SIM_SUBSCRIBES:
            return
        if sim.poll() is not None:
            raise AssertionError(f"the sim exited early:\n{sim.communicate()}")
        time.sleep(0.2)
    raise AssertionError(f"the sim's topics never appeared; the endpoint has {_state(master)}")


def _finish(processes: Mapping[str, subprocess.Popen[str]], timeout: float) -> dict[str, str]:
    """Wait for every `rostopic echo -n 1`; returns the failures by topic."""
    failures: dict[str, str] = {}
    deadline = time.monotonic() + timeout
    for topic, process in processes.items():
        try:
            out, err = process.communicate(timeout=max(1.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            terminate(process)
            failures[topic] = "no message within the timeout"
            continue
        if process.returncode != 0 or not out.strip():
            failures[topic] = f"exit {process.returncode}: {err.strip()[-400:]}"
    return failures


def test_rostopic_echo_every_topic_the_sim_publishes(graph: RosMaster) -> None:
    topics = sorted(_state(graph)[0])
    assert any(t.startswith("/camera") for t in topics), topics
    echoes = {t: graph.spawn(["rostopic", "echo", "-n", "1", "--noarr", t]) for t in topics}
    try:
        failures = _finish(echoes, timeout=120)
    finally:
        for process in echoes.values():
            terminate(process)
    assert failures == {}


def test_rostopic_pub_and_echo_every_topic_the_sim_subscribes(graph: RosMaster) -> None:
    topics = sorted(_state(graph)[1])
    known = dict(_master_call(graph, "getTopicTypes"))
    pubs, echoes = [], {}
    try:
        for topic in topics:
            # Empty messages: the sim rejects them (logged), but the ROS tools must load them.
            pubs.append(graph.spawn(["rostopic", "pub", "-r", "5", topic, known[topic], "{}"]))
            echoes[topic] = graph.spawn(["rostopic", "echo", "-n", "1", "--noarr", topic])
        failures = _finish(echoes, timeout=120)
    finally:
        for process in [*pubs, *echoes.values()]:
            terminate(process)
    assert failures == {}
