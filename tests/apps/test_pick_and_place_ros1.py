"""Pick and place with ROS 1: the planner as a real rospy node, and the whole demo on roscore."""

from __future__ import annotations

import contextlib
import json
import os
import queue
import signal
import socket
import subprocess
import sys
import threading
import time
import xmlrpc.client
from collections.abc import Iterator
from typing import IO, Any

import numpy as np
import pytest
import yaml

from simbridge.apps.pick_and_place import PLANNER_SERVICE, SERVICE_TYPE, PickAndPlaceTask
from simbridge.apps.pick_and_place.conversion import pose_to_msg
from simbridge.endpoint.backends.ros1 import generate_python_messages, master_answers
from simbridge.messages import default_registry
from simbridge.planning import Pose, top_down_orientation
from tests.ros1support import RosMaster, require_ros, shared_master

pytestmark = [
    pytest.mark.ros1,
    pytest.mark.timeout(180),
    pytest.mark.filterwarnings("ignore:notifyAll:DeprecationWarning"),
]

REG = default_registry()
GRASP_OFFSET = 0.05


@pytest.fixture(scope="module")
def master() -> RosMaster:
    require_ros()
    return shared_master()


def wait_for(predicate: Any, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.05)


@pytest.fixture(scope="module")
def planner_node(master: RosMaster) -> Iterator[subprocess.Popen[str]]:
    command = [sys.executable, "-m", "simbridge.cli", "planner", "--backend", "ros1"]
    with master.running(command) as node:
        lookup = xmlrpc.client.ServerProxy(master.uri)

        def ready() -> bool:
            if node.poll() is not None:
                raise AssertionError(f"the planner node exited: {node.communicate()}")
            reply: Any = lookup.lookupService("/test_pick_and_place", PLANNER_SERVICE)
            return bool(reply[0] == 1)

        wait_for(ready, 60, "the planner node's service")
        yield node


def request_bytes(pick: Pose) -> bytes:
    task = PickAndPlaceTask()
    req = REG.new("niryo_moveit/MoverServiceRequest")
    req.pick_pose = pose_to_msg(REG, pick)
    req.place_pose = pose_to_msg(REG, task.place_pose(GRASP_OFFSET))
    return REG.encode(req)


def rospy_call(payload: bytes) -> Any:
    """Call /niryo_moveit with rospy and raw service classes from the message registry."""
    import rospy

    from simbridge.endpoint.backends.ros1 import Ros1Types, raw_service_class

    service_class = raw_service_class(Ros1Types(REG).service(SERVICE_TYPE))
    proxy = rospy.ServiceProxy(PLANNER_SERVICE, service_class)
    try:
        raw = proxy(service_class._request_class(payload))
    finally:
        proxy.close()
    return REG.decode(raw.payload, "niryo_moveit/MoverServiceResponse")


def lines_of(stream: IO[str]) -> queue.Queue[str]:
    lines: queue.Queue[str] = queue.Queue()

    def pump() -> None:
        for line in stream:
            lines.put(line)

    threading.Thread(target=pump, daemon=True).start()
    return lines


@pytest.fixture(scope="module")
def tool_env(master: RosMaster, tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """The master's environment plus genpy modules for niryo_moveit, as catkin would build."""
    root = tmp_path_factory.mktemp("catkin_ws")
    extra = generate_python_messages(REG, [SERVICE_TYPE], root)
    env = dict(master.env)
    for key, value in extra.items():
        env[key] = os.pathsep.join(v for v in (value, env.get(key, "")) if v)
    return env


def ros_tool(env: dict[str, str], *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        list(args), env=env, capture_output=True, text=True, timeout=60, check=False
    )


def test_rosservice_cli_sees_the_planner_node(
    tool_env: dict[str, str], planner_node: subprocess.Popen[str]
) -> None:
    kind = ros_tool(tool_env, "rosservice", "type", PLANNER_SERVICE)
    assert kind.returncode == 0, kind.stderr
    assert kind.stdout.strip() == SERVICE_TYPE
    info = ros_tool(tool_env, "rosservice", "info", PLANNER_SERVICE)
    assert info.returncode == 0, info.stderr
    assert "Node: /niryo_moveit_planner" in info.stdout
    assert f"Type: {SERVICE_TYPE}" in info.stdout
    assert "Args: joints_input pick_pose place_pose" in info.stdout


def test_rosservice_call_plans(
    tool_env: dict[str, str], planner_node: subprocess.Popen[str]
) -> None:
    task = PickAndPlaceTask()

    def pose(p: Pose) -> dict[str, Any]:
        x, y, z = (float(v) for v in p.position)
        qx, qy, qz, qw = (float(v) for v in p.orientation)
        return {"position": {"x": x, "y": y, "z": z},
                "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}}  # fmt: skip

    request = {
        "joints_input": {"joints": [0.0] * 6},
        "pick_pose": pose(task.pick_pose(GRASP_OFFSET)),
        "place_pose": pose(task.place_pose(GRASP_OFFSET)),
    }
    call = ros_tool(tool_env, "rosservice", "call", PLANNER_SERVICE, json.dumps(request))
    assert call.returncode == 0, call.stderr
    response = yaml.safe_load(call.stdout)
    assert len(response["trajectories"]) == 4
    points = response["trajectories"][3]["joint_trajectory"]["points"]
    last = points[-1]["time_from_start"]
    assert last["secs"] + last["nsecs"] * 1e-9 > 0.5
    assert response["trajectories"][0]["joint_trajectory"]["joint_names"] == [
        f"joint_{i}" for i in range(1, 7)
    ]


def test_rospy_client_gets_four_trajectories(
    master: RosMaster, planner_node: subprocess.Popen[str]
) -> None:
    task = PickAndPlaceTask()
    response = rospy_call(request_bytes(task.pick_pose(GRASP_OFFSET)))
    assert len(response.trajectories) == 4
    first = response.trajectories[0].joint_trajectory
    assert list(first.joint_names) == [f"joint_{i}" for i in range(1, 7)]
    assert np.allclose(first.points[0].positions, 0.0)
    times = [p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in first.points]
    assert times[0] == 0.0
    assert np.all(np.diff(times) > 0)


def test_unreachable_goal_empty_answer_and_error_on_rosout(
    master: RosMaster, planner_node: subprocess.Popen[str]
) -> None:
    with master.running(["rostopic", "echo", "/rosout/msg"]) as echo:
        assert echo.stdout is not None
        lines = lines_of(echo.stdout)
        far = Pose([0.0, 0.95, 0.3], top_down_orientation())
        # rostopic needs a moment to connect to the planner's /rosout publisher: call until seen
        seen: list[str] = []
        deadline = time.monotonic() + 30
        while not any("unreachable" in line for line in seen):
            assert time.monotonic() < deadline, f"no planner error on /rosout; got {seen}"
            response = rospy_call(request_bytes(far))
            assert list(response.trajectories) == []
            with contextlib.suppress(queue.Empty):
                while True:
                    seen.append(lines.get(timeout=1.0))
    assert planner_node.poll() is None  # still serving


def test_ros1_demo_end_to_end_starts_its_own_roscore(
    tmp_path: Any, request: pytest.FixtureRequest
) -> None:
    require_ros()
    env = dict(os.environ)
    held = socket.socket()  # bound, never listening, for the whole test: nothing listens
    held.bind(("127.0.0.1", 0))  # there, and no other master can take the port meanwhile
    request.addfinalizer(held.close)
    env["ROS_MASTER_URI"] = f"http://127.0.0.1:{held.getsockname()[1]}/"
    env["ROS_HOME"] = str(tmp_path)
    command = [
        *(sys.executable, "-m", "simbridge.apps.pick_and_place"),
        *("--backend", "ros1", "--json", "--seed", "3"),
    ]
    app = subprocess.Popen(
        command,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
        start_new_session=True,
    )
    try:
        out, err = app.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(app.pid, signal.SIGKILL)
        out, err = app.communicate()
        pytest.fail(f"the ros1 demo hung:\n{out}\n{err}")
    assert app.returncode == 0, f"{out}\n{err}"
    lines = out.strip().splitlines()
    summary = json.loads(lines[-1])
    assert summary["success"] is True
    assert summary["backend"] == "ros1"
    assert summary["cube_error_m"] < 0.02
    assert summary["trajectories"] == 4
    assert summary["target"] == pytest.approx(PickAndPlaceTask.random(3).target_center, abs=1e-4)
    started = [line for line in lines if "ROS master" in line and "(started)" in line]
    assert started, out
    uri = started[0].split("ROS master ")[1].split(" ")[0]
    assert not master_answers(uri)  # the demo stopped the roscore it started
    # ... after its node left it: rospy no longer warns at exit that it cannot unregister
    assert "WARNING" not in err, err
