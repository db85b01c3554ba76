"""Recording (`simbridge sim --record`) and replay (`simbridge play`) end to end: a scene
served through a real endpoint, read back with rosbags and `rosbag info`, replayed into
an endpoint and received by a connector."""

from __future__ import annotations

import contextlib
import queue
import shutil
import subprocess
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from rosbags.highlevel import AnyReader

from simbridge.connector import Connector, ConnectorOptions
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.errors import SimError
from simbridge.messages import default_registry, registry_for
from simbridge.sim.record import PlayOptions, Recorder, RecordOptions, play
from simbridge.sim.runner import SimulationSession
from tests.sim.urdf_samples import GRAVITY_ARM

REG = default_registry()
DURATION = 0.5
"""Sim seconds recorded: /joint_states and /tf at 50 Hz, /clock at 100 Hz (see `_scene`)."""


@pytest.fixture(params=["ROS1", "ROS2"])
def endpoint(request: pytest.FixtureRequest) -> Iterator[EndpointThread]:
    """A local endpoint speaking ROS 1 binary or CDR (ROS 2 layouts): the recorder
    converts to the file's format either way."""
    server = EndpointThread(EndpointOptions(port=0), LocalBus(request.param)).start()
    yield server
    server.stop()


def _scene(tmp_path: Path) -> Path:
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    scene: dict[str, Any] = {
        "physics": {"timestep": 0.002, "realtime_factor": 0},
        "robots": [{"urdf": "arm.urdf"}],
        "ros": {"enabled": True, "joint_states_rate": 50, "tf_rate": 50, "clock_rate": 100},
    }
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene))
    return path


def _record(tmp_path: Path, endpoint: EndpointThread, out: Path) -> None:
    """Run the arm scene for DURATION sim seconds, recording; a node sends one command."""
    session = SimulationSession(
        _scene(tmp_path),
        f"127.0.0.1:{endpoint.port}",
        connect_timeout=5,
        record=RecordOptions(out),
    )
    with session:
        assert session.connector is not None
        assert session.connector.flush(5)
        node_bus = endpoint.backend
        assert isinstance(node_bus, LocalBus)
        node = Node(node_bus, "/tester")
        try:
            cmd = registry_for(node_bus.protocol).new("std_msgs/Float64MultiArray", data=[0.1, 0.2])
            topic = "/joint_group_position_controller/command"
            pub = node.advertise(topic, "std_msgs/Float64MultiArray")
            deadline = time.monotonic() + 5
            while session.recorder is not None and time.monotonic() < deadline:
                if session.recorder.topic_counts()[topic]:
                    break
                pub.publish(cmd)  # until the sim's subscription is in place
                session.world.step()
                time.sleep(0.05)
            session.run(DURATION, realtime_factor=0)
            assert session.connector.flush(5)
        finally:
            node.close()


def _read(path: Path) -> tuple[Counter[str], dict[str, list[int]], dict[str, list[Any]]]:
    counts: Counter[str] = Counter()
    stamps: dict[str, list[int]] = {}
    msgs: dict[str, list[Any]] = {}
    with AnyReader([path]) as reader:
        for conn in reader.connections:
            assert conn.msgdef.data, f"{conn.topic} has no message definition"
        for conn, stamp, data in reader.messages():
            counts[conn.topic] += 1
            stamps.setdefault(conn.topic, []).append(stamp)
            msgs.setdefault(conn.topic, []).append(reader.deserialize(data, conn.msgtype))
    return counts, stamps, msgs


def _check_recording(path: Path) -> None:
    counts, stamps, msgs = _read(path)
    assert {"/joint_states", "/tf", "/tf_static", "/clock"} <= set(counts), counts
    assert counts["/joint_group_position_controller/command"] >= 1, "received topic recorded"
    # rates are in sim time: 50 Hz and 100 Hz over DURATION (plus the steps before it)
    assert 0.9 * 50 * DURATION <= counts["/joint_states"] <= 50 * (DURATION + 1)
    assert 0.9 * 100 * DURATION <= counts["/clock"] <= 100 * (DURATION + 1)
    for topic, seq in stamps.items():
        assert seq == sorted(seq), f"{topic} stamps go back"
    # the bag time of each message is the sim time it carries
    for stamp, clock in zip(stamps["/clock"], msgs["/clock"], strict=True):
        assert stamp == clock.clock.sec * 10**9 + clock.clock.nanosec
    for stamp, js in zip(stamps["/joint_states"], msgs["/joint_states"], strict=True):
        assert abs(stamp - (js.header.stamp.sec * 10**9 + js.header.stamp.nanosec)) < 10**6
        assert len(js.position) == len(js.name) > 0
    assert list(msgs["/joint_group_position_controller/command"][0].data) == [0.1, 0.2]


def test_record_mcap(tmp_path: Path, endpoint: EndpointThread) -> None:
    out = tmp_path / "run.mcap"
    _record(tmp_path, endpoint, out)
    assert out.is_file()
    assert out.read_bytes()[:8] == b"\x89MCAP0\r\n"
    assert not (tmp_path / "run.mcap.rosbag2").exists()
    _check_recording(out)


@pytest.mark.skipif(shutil.which("rosbag") is None, reason="python3-rosbag not installed")
def test_record_ros1_bag_opens_in_rosbag_info(tmp_path: Path, endpoint: EndpointThread) -> None:
    out = tmp_path / "run.bag"
    _record(tmp_path, endpoint, out)
    _check_recording(out)
    info = subprocess.run(
        ["rosbag", "info", "--yaml", str(out)],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    data = yaml.safe_load(info.stdout)
    topics = {t["topic"]: t for t in data["topics"]}
    assert topics["/joint_states"]["type"] == "sensor_msgs/JointState"
    assert topics["/tf"]["type"] == "tf2_msgs/TFMessage"
    counts, _, _ = _read(out)
    assert topics["/joint_states"]["messages"] == counts["/joint_states"]
    assert data["messages"] == sum(counts.values())


def test_play_into_endpoint(tmp_path: Path, endpoint: EndpointThread) -> None:
    out = tmp_path / "run.mcap"
    _record(tmp_path, endpoint, out)
    counts, _, _ = _read(out)
    listener = Connector("127.0.0.1", endpoint.port, ConnectorOptions()).connect(wait=5)
    player = Connector("127.0.0.1", endpoint.port, ConnectorOptions()).connect(wait=5)
    try:
        got: queue.Queue[Any] = queue.Queue()
        clocks: queue.Queue[Any] = queue.Queue()
        listener.subscribe("/joint_states", "sensor_msgs/JointState", got.put)
        listener.subscribe("/clock", "rosgraph_msgs/Clock", clocks.put)
        assert listener.flush(5)
        listener.endpoint_stats()  # a barrier: the endpoint holds both subscriptions
        start = time.monotonic()
        stats = play(out, player, PlayOptions(rate=2.0))
        elapsed = time.monotonic() - start
        assert player.flush(5)
        assert stats.sent == sum(n for t, n in counts.items() if t != "/clock")
        assert stats.failed == 0
        # --rate 2 plays the ~DURATION s of sim time in about half of it
        assert elapsed >= 0.9 * DURATION / 2
        received = _drain(got, counts["/joint_states"])
        assert len(received) == counts["/joint_states"]
        times = [c.clock.sec + c.clock.nanosec * 1e-9 for c in _drain(clocks, 10)]
        assert times == sorted(times)
        assert times[-1] > 0
    finally:
        player.close()
        listener.close()


def _drain(q: queue.Queue[Any], want: int, timeout: float = 5.0) -> list[Any]:
    items: list[Any] = []
    deadline = time.monotonic() + timeout
    while len(items) < want and time.monotonic() < deadline:
        with contextlib.suppress(queue.Empty):
            items.append(q.get(timeout=0.1))
    return items


def test_full_buffer_drops_are_counted(tmp_path: Path) -> None:
    msg = REG.encode(REG.new("std_msgs/Float64MultiArray", data=[1.0] * 100))
    recorder = Recorder(RecordOptions(tmp_path / "small.mcap", buffer=1), clock=lambda: 1.0)
    sent = 2000
    for _ in range(sent):
        recorder.put("/x", "std_msgs/Float64MultiArray", msg, REG, "ros1")
    stats = recorder.close()
    assert stats.dropped > 0
    assert stats.written + stats.dropped == sent
    counts, _, _ = _read(tmp_path / "small.mcap")
    assert counts["/x"] == stats.written
    # the byte bound holds too: nothing larger than it is ever queued
    tiny = Recorder(RecordOptions(tmp_path / "tiny.bag", buffer_bytes=100), clock=lambda: 1.0)
    for _ in range(10):
        tiny.put("/x", "std_msgs/Float64MultiArray", msg, REG, "ros1")
    assert len(msg) > 100
    assert (tiny.close().written, tiny.close().dropped) == (0, 10)


def test_bad_file_names_are_refused(tmp_path: Path) -> None:
    with pytest.raises(SimError, match=r"\.mcap"):
        Recorder(RecordOptions(tmp_path / "run.txt"), clock=lambda: 0.0)
    (tmp_path / "there.bag").write_bytes(b"")
    with pytest.raises(SimError, match="exists"):
        Recorder(RecordOptions(tmp_path / "there.bag"), clock=lambda: 0.0)
    with pytest.raises(SimError, match="needs an endpoint"):
        SimulationSession(_scene(tmp_path), None, record=RecordOptions(tmp_path / "a.mcap"))


def test_mobile_robot_demo_records_sensors_and_commands(tmp_path: Path) -> None:
    from simbridge.apps.mobile_robot.runner import run_mobile_robot

    out = tmp_path / "demo.bag"
    result = run_mobile_robot(0.2, record=RecordOptions(out), progress=None)
    assert result.success
    counts, stamps, _ = _read(out)
    # what the sim publishes (sensors included) and the /cmd_vel it receives
    assert {"/scan", "/odom", "/imu", "/camera/image_raw", "/tf", "/cmd_vel"} <= set(counts)
    assert counts["/cmd_vel"] > 10
    assert all(seq == sorted(seq) for seq in stamps.values())


def test_play_command_line(
    tmp_path: Path, endpoint: EndpointThread, capsys: pytest.CaptureFixture[str]
) -> None:
    from simbridge.cli import main

    out = tmp_path / "run.bag"
    _record(tmp_path, endpoint, out)
    counts, _, _ = _read(out)
    assert main(["play", str(out), "--endpoint", f"127.0.0.1:{endpoint.port}", "--rate", "0"]) == 0
    sent = sum(n for topic, n in counts.items() if topic != "/clock")
    assert f"played {sent} messages on {len(counts) - 1} topics" in capsys.readouterr().out
    assert main(["play", str(tmp_path / "none.mcap"), "--endpoint", "127.0.0.1:1"]) == 2
    assert "none.mcap' does not exist" in capsys.readouterr().err
