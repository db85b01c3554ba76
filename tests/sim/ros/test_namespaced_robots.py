"""Several robots with their own `ros:` blocks (namespace, frame prefix) on the local bus:
two copies of one URDF, each with <ns>/joint_states, its own commands and prefixed TF
frames on the shared /tf and /tf_static."""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from simbridge.assets import robot_urdf
from simbridge.connector import Connector, ConnectorOptions
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.errors import SimError
from simbridge.messages import default_registry
from simbridge.sim.ros import SimRosBridge
from simbridge.sim.scene import load_scene
from simbridge.sim.urdf import forward_kinematics, parse_urdf
from simbridge.sim.world import World
from tests.sim.bridged import BridgedWorld
from tests.sim.urdf_samples import GRAVITY_ARM
from tests.sim.worlds import arm_scene
from tests.waiting import wait_for

REG = default_registry()
ARM_JOINTS = ["shoulder", "elbow", "wrist", "grip_a", "grip_b"]


def two_arm_scene(tmp_path: Path, **extra: Any) -> Path:
    scene = {
        "physics": {"timestep": 0.002, "gravity": [0, 0, 0]},
        "robots": [
            {
                "urdf": "arm.urdf",
                "base": {"xyz": [0, 0.5, 0]},
                "initial_positions": {"shoulder": 0.3},
                "ros": {"namespace": "/arm_left", "frame_prefix": "arm_left/"},
            },
            {
                "urdf": "arm.urdf",
                "base": {"xyz": [0, -0.5, 0]},
                "initial_positions": {"shoulder": -0.2},
                "ros": {"namespace": "/arm_right", "frame_prefix": "arm_right/", **extra},
            },
        ],
    }
    return arm_scene(tmp_path, scene)


@pytest.fixture
def rig(tmp_path: Path, bridged: Callable[[World], BridgedWorld]) -> BridgedWorld:
    return bridged(World.from_scene(load_scene(two_arm_scene(tmp_path))))


def _collect(node: Node, topic: str, msg_type: str) -> queue.Queue[Any]:
    got: queue.Queue[Any] = queue.Queue()
    node.subscribe(topic, msg_type, got.put)
    return got


def test_loader_defaults_names_and_prefixes_from_the_ros_block(tmp_path: Path) -> None:
    scene = load_scene(two_arm_scene(tmp_path))
    left, right = scene.robots
    assert (left.name, left.prefix) == ("arm_left", "arm_left/")
    assert (right.name, right.prefix) == ("arm_right", "arm_right/")
    assert left.ros is not None
    assert left.ros.namespace == "/arm_left"
    world = World.from_scene(scene)
    assert "arm_left/shoulder" in world.joint_names()
    assert "arm_right/shoulder" in world.joint_names()


def test_bad_namespace_is_named(tmp_path: Path) -> None:
    with pytest.raises(SimError, match=r"robots\[1\]\.ros\.namespace.*'/arm-2'"):
        load_scene(two_arm_scene(tmp_path, namespace="/arm-2"))
    with pytest.raises(SimError, match=r"robots\[1\]\.ros: unknown key 'bogus'"):
        load_scene(two_arm_scene(tmp_path, bogus=1))


def test_each_robot_publishes_its_own_joint_states(rig: BridgedWorld) -> None:
    left = _collect(rig.node, "/arm_left/joint_states", "sensor_msgs/JointState")
    right = _collect(rig.node, "/arm_right/joint_states", "sensor_msgs/JointState")
    for got, shoulder in ((left, 0.3), (right, -0.2)):
        msg = got.get(timeout=5)
        assert list(msg.name) == ARM_JOINTS  # URDF names, no MuJoCo prefix
        assert dict(zip(msg.name, msg.position, strict=True))["shoulder"] == pytest.approx(
            shoulder, abs=2e-3
        )
    # Every robot has its own block: no scene-wide /joint_states is advertised.
    assert rig.bridge.state.shared_joints == []
    assert "/joint_states" not in rig.bridge.state.topics


def _edges(msg: Any) -> dict[str, tuple[str, Any]]:
    return {t.child_frame_id: (t.header.frame_id, t.transform) for t in msg.transforms}


def test_tf_tree_has_prefixed_frames_under_one_world(rig: BridgedWorld) -> None:
    tf = _collect(rig.node, "/tf", "tf2_msgs/TFMessage")
    static = _collect(rig.node, "/tf_static", "tf2_msgs/TFMessage")
    parents: dict[str, tuple[str, Any]] = {}
    parents.update(_edges(static.get(timeout=5)))
    parents.update(_edges(tf.get(timeout=5)))
    for side in ("arm_left", "arm_right"):
        for link in ("base", "upper", "fore", "spin", "finger_a", "finger_b"):
            assert f"{side}/{link}" in parents, f"{side}/{link} missing from TF"
        assert parents[f"{side}/upper"][0] == f"{side}/base"
    assert parents["arm_left/base"][0] == parents["arm_right/base"][0] == "world"
    # A tree: every frame reaches "world" without a cycle.
    for frame in parents:
        seen, at = set(), frame
        while at != "world":
            assert at not in seen, f"{frame}: TF cycle"
            assert at in parents, f"{frame} does not reach world"
            seen.add(at)
            at = parents[at][0]
    # Geometry: each base sits where the scene put it; joints follow each robot's state.
    left_base = parents["arm_left/base"][1].translation
    right_base = parents["arm_right/base"][1].translation
    assert (left_base.y, right_base.y) == pytest.approx((0.5, -0.5), abs=1e-9)
    fk = parse_urdf(GRAVITY_ARM)
    for side, shoulder in (("arm_left", 0.3), ("arm_right", -0.2)):
        expected = forward_kinematics(fk, {"shoulder": shoulder})
        rel = expected["base"].inverse() @ expected["upper"]
        got = parents[f"{side}/upper"][1].rotation
        qx, qy, qz, qw = rel.quat_xyzw
        sign = 1.0 if got.w * qw >= 0 else -1.0
        assert [got.x, got.y, got.z, got.w] == pytest.approx(
            [sign * qx, sign * qy, sign * qz, sign * qw], abs=2e-3
        )


def _trajectory(names: list[str], t: float, positions: list[float]) -> Any:
    point = REG.new("trajectory_msgs/JointTrajectoryPoint", positions=np.array(positions))
    point.time_from_start = REG.new(
        "builtin_interfaces/Duration", sec=int(t), nanosec=round((t - int(t)) * 1e9)
    )
    return REG.new("trajectory_msgs/JointTrajectory", joint_names=names, points=[point])


def test_commands_reach_only_their_robot(rig: BridgedWorld) -> None:
    left = rig.node.advertise("/arm_left/joint_trajectory", "trajectory_msgs/JointTrajectory")
    right = rig.node.advertise(
        "/arm_right/joint_group_position_controller/command", "std_msgs/Float64MultiArray"
    )
    left.publish(_trajectory(["shoulder", "elbow"], 0.3, [0.8, -0.5]))
    q = rig.world.joint_positions
    left_want = {"arm_left/shoulder": 0.8, "arm_left/elbow": -0.5}
    assert wait_for(lambda: all(abs(q()[j] - v) < 2e-3 for j, v in left_want.items()))
    assert q()["arm_right/shoulder"] == pytest.approx(-0.2, abs=2e-3)
    assert q()["arm_right/elbow"] == pytest.approx(0.0, abs=2e-3)
    # The right arm's group: its driven joints in URDF order (grip_b mimics grip_a).
    right.publish(REG.new("std_msgs/Float64MultiArray", data=np.array([0.1, 0.2, 0.3, 0.01])))
    want = {"arm_right/shoulder": 0.1, "arm_right/elbow": 0.2, "arm_right/wrist": 0.3}
    assert wait_for(lambda: all(abs(q()[j] - v) < 2e-3 for j, v in want.items()))
    assert q()["arm_left/shoulder"] == pytest.approx(0.8, abs=2e-3)


def test_one_robots_trajectory_does_not_cancel_the_others(rig: BridgedWorld) -> None:
    left = rig.node.advertise("/arm_left/joint_trajectory", "trajectory_msgs/JointTrajectory")
    right = rig.node.advertise("/arm_right/joint_trajectory", "trajectory_msgs/JointTrajectory")
    left.publish(_trajectory(["elbow"], 1.0, [0.7]))
    right.publish(_trajectory(["elbow"], 1.0, [-0.7]))
    q = rig.world.joint_positions
    assert wait_for(
        lambda: abs(q()["arm_left/elbow"] - 0.7) < 2e-3 and abs(q()["arm_right/elbow"] + 0.7) < 2e-3
    )


def test_ros2_endpoint_gets_namespaced_joint_states_and_skips_controllers(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    from simbridge.messages import ros2_registry
    from simbridge.sim.runner import SimulationSession

    path = two_arm_scene(tmp_path)
    scene = yaml.safe_load(path.read_text())
    scene["robots"][0]["ros"]["controllers"] = {
        "arm_controller": {"type": "joint_trajectory_controller", "joints": ["shoulder"]}
    }
    path.write_text(yaml.safe_dump(scene))
    with EndpointThread(EndpointOptions(port=0), LocalBus("ROS2")) as endpoint:
        bus = endpoint.backend
        assert isinstance(bus, LocalBus)
        got: queue.Queue[Any] = queue.Queue()
        with Node(bus, "/ros2_tester") as node:
            node.subscribe("/arm_left/joint_states", "sensor_msgs/JointState", got.put)
            address = f"127.0.0.1:{endpoint.port}"
            with SimulationSession(path, address, connect_timeout=5) as session:
                assert session.bridge is not None
                assert session.bridge.robots["arm_left"].controllers == {}
                session.run(duration=0.2)
                msg = got.get(timeout=5)
    assert type(msg) is ros2_registry().msg_class("sensor_msgs/JointState")
    assert list(msg.name) == ARM_JOINTS
    assert "cannot host their action servers" in caplog.text


def test_own_connection_keeps_one_robot_going_when_the_others_connection_drops(
    tmp_path: Path,
) -> None:
    from simbridge.sim.runner import SimulationSession

    path = two_arm_scene(tmp_path)
    scene = yaml.safe_load(path.read_text())
    scene["robots"][1]["ros"]["own_connection"] = True
    path.write_text(yaml.safe_dump(scene))
    with EndpointThread(EndpointOptions(port=0)) as endpoint:
        bus = endpoint.backend
        assert isinstance(bus, LocalBus)
        with Node(bus, "/tester") as node:
            left = _collect(node, "/arm_left/joint_states", "sensor_msgs/JointState")
            right = _collect(node, "/arm_right/joint_states", "sensor_msgs/JointState")
            address = f"127.0.0.1:{endpoint.port}"
            with SimulationSession(path, address, connect_timeout=5) as session:
                assert session.bridge is not None
                assert set(session.bridge.robots) == {"arm_left"}
                link = session.robot_bridges["arm_right"]
                assert link.connector is not session.connector
                runner = threading.Thread(target=session.run, kwargs={"realtime_factor": 1.0})
                runner.start()
                try:
                    assert left.get(timeout=5).name[0] == "shoulder"
                    assert right.get(timeout=5).name[0] == "shoulder"
                    pub = node.advertise(
                        "/arm_right/joint_group_position_controller/command",
                        "std_msgs/Float64MultiArray",
                    )
                    pub.publish(
                        REG.new("std_msgs/Float64MultiArray", data=np.array([0.4, 0, 0, 0]))
                    )
                    q = session.world.joint_positions
                    assert wait_for(lambda: abs(q()["arm_right/shoulder"] - 0.4) < 2e-3)
                    # The shared connection fails; the right arm's own one keeps publishing.
                    assert session.connector is not None
                    session.connector.close()
                    time.sleep(0.3)
                    while not right.empty():
                        right.get_nowait()
                    assert right.get(timeout=5).name[0] == "shoulder"
                finally:
                    session.world.stop()
                    runner.join(5)


def test_each_robot_has_its_own_diff_drive(tmp_path: Path) -> None:
    diffbot = robot_urdf("diffbot")
    wheels = {"mode": "velocity", "damping": 2, "force_limit": 2}
    drives = {
        "joints": {
            "left_wheel_joint": wheels,
            "right_wheel_joint": wheels,
            "caster_swivel_joint": {"mode": "none"},
            "caster_wheel_joint": {"mode": "none"},
        }
    }
    robots = [
        {
            "urdf": str(diffbot), "fixed_base": False, "drives": drives,
            "base": {"xyz": [0, y, 0.05]},
            "ros": {"namespace": f"/{name}",
                    "diff_drive": {"left": "left_wheel_joint", "right": "right_wheel_joint"}},
        }
        for name, y in (("bot_a", 1.0), ("bot_b", -1.0))
    ]  # fmt: skip
    scene = {"objects": [{"name": "floor", "type": "plane"}], "robots": robots}
    (tmp_path / "bots.yaml").write_text(yaml.safe_dump(scene))
    with EndpointThread(EndpointOptions(port=0)) as endpoint:
        bus = endpoint.backend
        assert isinstance(bus, LocalBus)
        connector = Connector("127.0.0.1", endpoint.port, ConnectorOptions()).connect(wait=5)
        world = World.from_scene(load_scene(tmp_path / "bots.yaml"))
        bridge = SimRosBridge(world, connector).start()
        try:
            link = bridge.robots["bot_a"].diff_drive
            assert link is not None
            assert link.config.topic == "/bot_a/cmd_vel"
            assert link.config.left_joint == "bot_a/left_wheel_joint"
            with Node(bus, "/driver") as node:
                pub = node.advertise("/bot_a/cmd_vel", "geometry_msgs/Twist")
                assert connector.flush(5)
                connector.endpoint_stats()  # a barrier: the endpoint holds the subscription
                root = world.robots["bot_a"].prefix + world.robots["bot_a"].robot.root
                other = world.robots["bot_b"].prefix + world.robots["bot_b"].robot.root
                start_a, start_b = world.link_pose(root).xyz, world.link_pose(other).xyz
                twist = REG.new("geometry_msgs/Twist", linear={"x": 0.3})
                for _ in range(10):
                    pub.publish(twist)
                    time.sleep(0.02)
                    world.step(100)
                moved_a = world.link_pose(root).xyz[0] - start_a[0]
                moved_b = world.link_pose(other).xyz[0] - start_b[0]
            assert moved_a > 0.2  # ~0.3 m/s for 2 s, less the ramp
            assert abs(moved_b) < 0.01
        finally:
            bridge.close()
            connector.close()
