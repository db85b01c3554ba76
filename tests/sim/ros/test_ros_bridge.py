"""The simulator's ROS interfaces end to end: World, Connector, endpoint, local-bus node."""

from __future__ import annotations

import math
import queue
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.messages import default_registry
from simbridge.sim.ros import STEP_SRV, trajectory_from_message
from simbridge.sim.urdf import forward_kinematics, parse_urdf
from simbridge.sim.world import World
from tests.sim.bridged import BridgedWorld
from tests.sim.urdf_samples import GRAVITY_ARM
from tests.sim.worlds import arm_world
from tests.waiting import wait_for

REG = default_registry()


@pytest.fixture
def rig_factory(
    tmp_path: Path, bridged: Callable[[World], BridgedWorld]
) -> Callable[..., BridgedWorld]:
    def make(**overrides: Any) -> BridgedWorld:
        ros = {"enabled": True, **overrides.pop("ros", {})}
        return bridged(arm_world(tmp_path, ros=ros, **overrides))

    return make


def _collect(node: Node, topic: str, msg_type: str) -> queue.Queue[Any]:
    got: queue.Queue[Any] = queue.Queue()
    node.subscribe(topic, msg_type, got.put)
    return got


def _stamp(msg: Any) -> float:
    return float(msg.sec) + float(msg.nanosec) * 1e-9


def test_joint_states_tf_and_clock(rig_factory: Callable[..., BridgedWorld]) -> None:
    rig = rig_factory(robot={"initial_positions": {"shoulder": -0.4, "elbow": 0.6}})
    states = _collect(rig.node, "/joint_states", "sensor_msgs/JointState")
    tf = _collect(rig.node, "/tf", "tf2_msgs/TFMessage")
    static = _collect(rig.node, "/tf_static", "tf2_msgs/TFMessage")
    clock = _collect(rig.node, "/clock", "rosgraph_msgs/Clock")
    first = states.get(timeout=5)
    second = states.get(timeout=5)
    assert list(first.name) == rig.world.joint_names()
    assert len(first.position) == len(first.velocity) == len(first.effort) == len(first.name)
    positions = dict(zip(first.name, first.position, strict=True))
    assert positions["shoulder"] == pytest.approx(-0.4, abs=2e-3)
    assert positions["elbow"] == pytest.approx(0.6, abs=2e-3)
    # 50 Hz in sim time: stamps are multiples of 0.02 s, 0.02 s apart
    t1, t2 = _stamp(first.header.stamp), _stamp(second.header.stamp)
    assert t2 - t1 == pytest.approx(0.02, abs=1e-9)
    assert t1 / 0.02 == pytest.approx(round(t1 / 0.02), abs=1e-6)

    expected = forward_kinematics(parse_urdf(GRAVITY_ARM), {"shoulder": -0.4, "elbow": 0.6})
    msg = tf.get(timeout=5)
    edges = {(t.header.frame_id, t.child_frame_id): t.transform for t in msg.transforms}
    assert set(edges) == {
        ("base", "upper"),
        ("upper", "fore"),
        ("fore", "spin"),
        ("spin", "finger_a"),
        ("spin", "finger_b"),
    }
    rel = expected["upper"].inverse() @ expected["fore"]
    got = edges[("upper", "fore")]
    assert [got.translation.x, got.translation.y, got.translation.z] == pytest.approx(
        list(rel.xyz), abs=1e-6
    )
    qx, qy, qz, qw = rel.quat_xyzw
    sign = math.copysign(1.0, got.rotation.w * qw) if got.rotation.w * qw else 1.0
    assert [got.rotation.x, got.rotation.y, got.rotation.z, got.rotation.w] == pytest.approx(
        [sign * qx, sign * qy, sign * qz, sign * qw], abs=2e-3
    )

    latched = static.get(timeout=5)
    assert [(t.header.frame_id, t.child_frame_id) for t in latched.transforms] == [
        ("world", "base")
    ]
    c1, c2 = _stamp(clock.get(timeout=5).clock), _stamp(clock.get(timeout=5).clock)
    assert c2 - c1 == pytest.approx(0.01, abs=1e-9)


def _trajectory(names: list[str], points: list[tuple[float, list[float]]]) -> Any:
    msg = REG.new("trajectory_msgs/JointTrajectory", joint_names=names)
    for t, positions in points:
        point = REG.new("trajectory_msgs/JointTrajectoryPoint", positions=np.array(positions))
        point.time_from_start = REG.new(
            "builtin_interfaces/Duration", sec=int(t), nanosec=round((t - int(t)) * 1e9)
        )
        msg.points.append(point)
    return msg


def test_trajectory_command_is_followed(rig_factory: Callable[..., BridgedWorld]) -> None:
    rig = rig_factory()
    pub = rig.node.advertise("/joint_trajectory", "trajectory_msgs/JointTrajectory")
    pub.publish(_trajectory(["shoulder", "elbow"], [(0.2, [-0.3, 0.3]), (0.5, [-0.6, 0.9])]))
    assert wait_for(lambda: rig.world.follower.active is not None)
    assert wait_for(lambda: rig.world.follower.active is None)
    assert wait_for(lambda: abs(rig.world.joint_positions()["elbow"] - 0.9) < 2e-3)
    assert rig.world.joint_positions()["shoulder"] == pytest.approx(-0.6, abs=2e-3)


def test_group_position_and_velocity_commands(rig_factory: Callable[..., BridgedWorld]) -> None:
    rig = rig_factory(
        ros={"command_joints": ["shoulder", "elbow", "wrist"]}, physics={"gravity": [0, 0, 0]}
    )
    pos = rig.node.advertise(
        "/joint_group_position_controller/command", "std_msgs/Float64MultiArray"
    )
    vel = rig.node.advertise(
        "/joint_group_velocity_controller/command", "std_msgs/Float64MultiArray"
    )
    pos.publish(REG.new("std_msgs/Float64MultiArray", data=np.array([0.2, -0.3, 0.4])))
    want = {"shoulder": 0.2, "elbow": -0.3, "wrist": 0.4}
    assert wait_for(
        lambda: all(abs(rig.world.joint_positions()[j] - v) < 1e-3 for j, v in want.items())
    )
    vel.publish(REG.new("std_msgs/Float64MultiArray", data=np.array([0.0, 0.0, 1.5])))
    assert wait_for(lambda: abs(rig.world.joint_velocities()["wrist"] - 1.5) < 1e-2)
    pos.publish(REG.new("std_msgs/Float64MultiArray", data=np.array([1.0, 2.0])))  # wrong length
    commands = rig.bridge.commands
    assert commands is not None
    assert wait_for(lambda: bool(commands.errors))
    assert "2 values for 3 joints" in commands.errors[0]


def test_follower_mode_mirrors_joint_states(rig_factory: Callable[..., BridgedWorld]) -> None:
    rig = rig_factory(ros={"commands": {"follow_joint_states": "/gui/joint_states"}})
    pub = rig.node.advertise("/gui/joint_states", "sensor_msgs/JointState")
    msg = REG.new("sensor_msgs/JointState", name=["shoulder", "grip_a", "unknown_joint"])
    msg.position = np.array([0.7, 0.02, 5.0])
    pub.publish(msg)
    assert wait_for(lambda: abs(rig.world.joint_positions()["shoulder"] - 0.7) < 1e-3)
    assert rig.world.joint_positions()["grip_b"] == pytest.approx(-0.02, abs=1e-3)  # mimic


def test_pause_step_and_reset_services(rig_factory: Callable[..., BridgedWorld]) -> None:
    rig = rig_factory()
    assert wait_for(lambda: rig.world.time > 0.05)
    reply = rig.node.call(
        "/simbridge/pause", "std_srvs/SetBool", REG.new("std_srvs/SetBoolRequest", data=True)
    )
    assert reply.success
    paused_at = rig.world.time
    time.sleep(0.1)
    assert rig.world.time == paused_at
    stepped = rig.node.call("/simbridge/step", STEP_SRV, REG.new(f"{STEP_SRV}Request", steps=10))
    assert stepped.success
    assert stepped.sim_time == pytest.approx(paused_at + 10 * 0.002)
    rig.node.call("/simbridge/reset", "std_srvs/Empty", REG.new("std_srvs/EmptyRequest"))
    assert wait_for(lambda: rig.world.time == 0.0)
    rig.node.call(
        "/simbridge/pause", "std_srvs/SetBool", REG.new("std_srvs/SetBoolRequest", data=False)
    )
    assert wait_for(lambda: rig.world.time > 0.05)


def test_trajectory_message_conversion() -> None:
    msg = _trajectory(["a", "b"], [(0.5, [1.0, 2.0]), (1.25, [3.0, 4.0])])
    traj = trajectory_from_message(msg)
    assert traj is not None
    assert traj.joints == ("a", "b")
    assert [p.time for p in traj.points] == [0.5, 1.25]
    assert traj.points[0].velocities is None
    assert trajectory_from_message(REG.new("trajectory_msgs/JointTrajectory")) is None


def test_session_serves_scene_with_sensors(tmp_path: Path) -> None:
    import yaml

    from simbridge.sim.runner import SimulationSession

    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    (tmp_path / "scene.yaml").write_text(
        yaml.safe_dump(
            {
                "physics": {"realtime_factor": 1.0},
                "robots": [{"urdf": "arm.urdf"}],
                "sensors": [
                    {
                        "type": "imu",
                        "name": "wrist_imu",
                        "body": "fore",
                        "rate": 50,
                        "topic": "/wrist/imu",
                    }
                ],
            }
        )
    )
    with EndpointThread(EndpointOptions(port=0)) as endpoint:
        assert isinstance(endpoint.backend, LocalBus)
        with Node(endpoint.backend, "/tester") as node:
            imu = _collect(node, "/wrist/imu", "sensor_msgs/Imu")
            states = _collect(node, "/joint_states", "sensor_msgs/JointState")
            address = f"127.0.0.1:{endpoint.port}"
            scene = tmp_path / "scene.yaml"
            with SimulationSession(scene, address, connect_timeout=5) as session:
                assert session.connector is not None
                assert session.connector.flush(5)
                stats = session.run(duration=0.5)
                assert stats.steps == 250
                readings = [imu.get(timeout=5) for _ in range(20)]
                assert states.get(timeout=5).name
    # once the arm has settled, the IMU reads +g upward (the forearm is level at zero angles)
    assert readings[-1].linear_acceleration.z == pytest.approx(9.81, abs=0.05)


@pytest.mark.parametrize("text", ["localhost", "host:0", "host:http", ":99999"])
def test_bad_endpoint_text(text: str) -> None:
    from simbridge.errors import SimError
    from simbridge.sim.runner import parse_endpoint

    with pytest.raises(SimError, match="is not host:port"):
        parse_endpoint(text)
    assert parse_endpoint(":10000") == ("127.0.0.1", 10000)


def test_sensors_nobody_subscribes_to_cost_nothing(tmp_path: Path) -> None:
    import yaml

    from simbridge.sim.runner import SimulationSession

    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    imu = {"type": "imu", "body": "fore", "rate": 50}
    (tmp_path / "scene.yaml").write_text(
        yaml.safe_dump(
            {
                "robots": [{"urdf": "arm.urdf"}],
                "sensors": [
                    {**imu, "name": "read_imu", "topic": "/read/imu"},
                    {**imu, "name": "unread_imu", "topic": "/unread/imu"},
                ],
            }
        )
    )
    with EndpointThread(EndpointOptions(port=0)) as endpoint:
        assert isinstance(endpoint.backend, LocalBus)
        with Node(endpoint.backend, "/tester") as node:
            read = _collect(node, "/read/imu", "sensor_msgs/Imu")
            address = f"127.0.0.1:{endpoint.port}"
            with SimulationSession(tmp_path / "scene.yaml", address, connect_timeout=5) as session:
                assert session.connector is not None
                assert session.sensors is not None
                sensors = {s.name: s for s in session.sensors.suite.sensors}
                pubs = {t: session.sensors.publisher(t) for t in ("/read/imu", "/unread/imu")}
                assert wait_for(lambda: pubs["/read/imu"].subscriber_count == 1)
                assert wait_for(lambda: pubs["/unread/imu"].subscriber_count == 0)
                session.run(duration=0.2)
                assert sensors["read_imu"].active
                assert not sensors["unread_imu"].active
                assert read.get(timeout=5).linear_acceleration.z != 0.0
                # A late subscriber switches the sensor on.
                unread = _collect(node, "/unread/imu", "sensor_msgs/Imu")
                assert wait_for(lambda: pubs["/unread/imu"].subscriber_count == 1)
                session.run(duration=0.2)
                assert sensors["unread_imu"].active
                assert unread.get(timeout=5) is not None
