"""Everything published for one stamp describes the state at that stamp.

MuJoCo's `mj_step` advances qpos, qvel and time but leaves body poses, velocities and
accelerations describing the state one step earlier. /tf and sensors read those, so they
used to lag /joint_states by one step (2 ms) under the same stamp.
"""

from __future__ import annotations

import math
import threading
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
import yaml

from simbridge.connector import Connector, ConnectorOptions
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.sim.ros import SimRosBridge
from simbridge.sim.scene import load_scene
from simbridge.sim.sensors import Publication, attach_sensors
from simbridge.sim.urdf import parse_urdf
from simbridge.sim.urdf.kinematics import joint_motion
from simbridge.sim.urdf.transforms import Transform, quat_wxyz_to_matrix
from simbridge.sim.world import World
from tests.sim.urdf_samples import GRAVITY_ARM, inertial, joint, link, robot
from tests.sim.worlds import arm_world


def _stamp(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _transform(msg: Any) -> Transform:
    r, t = msg.rotation, msg.translation
    return Transform(quat_wxyz_to_matrix((r.w, r.x, r.y, r.z)), np.array([t.x, t.y, t.z]))


def test_tf_matches_fk_of_joint_states_with_the_same_stamp(tmp_path: Path) -> None:
    """Independent FK (the URDF's joint origins and axes, each joint at its published
    position, as robot_state_publisher computes it) against the sim's /tf while moving."""
    world = arm_world(tmp_path, ros={"enabled": True, "tf_rate": 50, "joint_states_rate": 50})
    urdf = parse_urdf(GRAVITY_ARM)
    states: dict[int, Any] = {}
    tfs: dict[int, Any] = {}
    with EndpointThread(EndpointOptions(port=0)) as endpoint:
        assert isinstance(endpoint.backend, LocalBus)
        with (
            Node(endpoint.backend, "/tester") as node,
            Connector("127.0.0.1", endpoint.port, ConnectorOptions()).connect(wait=5) as conn,
        ):
            lock = threading.Lock()

            def keep(into: dict[int, Any]) -> Any:
                def store(msg: Any) -> None:
                    header = msg.header if hasattr(msg, "header") else msg.transforms[0].header
                    with lock:
                        into[_stamp(header.stamp)] = msg

                return store

            node.subscribe("/joint_states", "sensor_msgs/JointState", keep(states))
            node.subscribe("/tf", "tf2_msgs/TFMessage", keep(tfs))
            with SimRosBridge(world, conn):
                assert conn.flush(5)
                # Swing the shoulder and elbow and spin the wrist: fast motion, so a
                # one-step lag is millimetres and degrees.
                for name, target in (("shoulder", 1.2), ("elbow", -1.0), ("wrist", 3.0)):
                    world.drives.set_position(name, target)
                world.run(duration=0.6, realtime_factor=2.0)
                assert conn.flush(5)
                for _ in range(100):
                    with lock:
                        if len(states) >= 30 and len(tfs) >= 30:
                            break
                    time.sleep(0.05)
    with lock:
        common = sorted(set(states) & set(tfs))
    assert len(common) >= 25
    moving = 0
    for stamp in common:
        positions = dict(zip(states[stamp].name, states[stamp].position, strict=True))
        velocities = dict(zip(states[stamp].name, states[stamp].velocity, strict=True))
        moving += max(abs(v) for v in velocities.values()) > 0.5
        for edge in tfs[stamp].transforms:
            joint = urdf.parent_joint(edge.child_frame_id)
            assert joint is not None
            assert joint.parent == edge.header.frame_id
            expected = joint.origin.transform @ joint_motion(joint, positions[joint.name])
            got = _transform(edge.transform)
            np.testing.assert_allclose(got.xyz, expected.xyz, atol=1e-9)
            np.testing.assert_allclose(got.rotation, expected.rotation, atol=1e-9)
    assert moving >= 10, "the arm barely moved; the test would not see a lag"


SENSOR_SCENE = {
    "physics": {"timestep": 0.002, "gravity": [0, 0, 0], "realtime_factor": 0},
    "objects": [
        {"name": "ball", "type": "sphere", "size": 0.1, "dynamic": True,
         "pose": {"xyz": [0.0, 0.0, 1.0]}},
    ],
    "ros": {"enabled": False},
}  # fmt: skip
LINEAR = np.array([0.5, -0.2, 0.1])
SPIN = 2.0  # rad/s about z


def test_odometry_and_imu_describe_the_state_at_their_stamp(tmp_path: Path) -> None:
    """A ball coasting in zero gravity: at stamp t it is at p0 + v t, turned by w t."""
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(SENSOR_SCENE))
    world = World.from_scene(load_scene(tmp_path / "scene.yaml"))
    joint = world.model.body("ball").jntadr[0]
    dof = world.model.jnt_dofadr[joint]
    world.data.qvel[dof : dof + 6] = [*LINEAR, 0.0, 0.0, SPIN]
    mujoco.mj_forward(world.model, world.data)
    published: dict[str, list[Publication]] = defaultdict(list)
    sensors = [
        {"type": "odometry", "name": "odom", "body": "ball", "origin": "world", "rate": 50},
        {"type": "imu", "name": "imu", "body": "ball", "rate": 100},
    ]
    attach_sensors(world, sensors, lambda pub: published[pub.topic].append(pub))
    world.step(500)
    start = np.array([0.0, 0.0, 1.0])
    odom = [pub.message for pub in published["odom"]]
    imu = [pub.message for pub in published["imu"]]
    assert len(odom) >= 49
    assert len(imu) >= 99
    for msg in odom:
        t = _stamp(msg.header.stamp) * 1e-9
        p = msg.pose.pose.position
        np.testing.assert_allclose([p.x, p.y, p.z], start + LINEAR * t, atol=1e-9)
    for msg in imu:
        t = _stamp(msg.header.stamp) * 1e-9
        q = msg.orientation
        yaw = 2 * math.atan2(q.z, q.w)
        assert math.remainder(yaw - SPIN * t, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
        assert msg.angular_velocity.z == pytest.approx(SPIN, abs=1e-9)


def test_sensors_and_callbacks_keep_their_rate_and_grid_for_minutes(tmp_path: Path) -> None:
    """Sensors and periodic callbacks over 120 s of sim time (float schedules fired
    sensors twice per tick from about 82 s on): one reading per tick, on the grid."""
    world = arm_world(tmp_path)
    steps: dict[str, list[int]] = defaultdict(list)

    def note_step(out: list[int]) -> Callable[[World], None]:
        return lambda w: out.append(round(w.time / 0.002))

    for rate in (100.0, 50.0, 30.0):
        world.add_step_callback(note_step(steps[f"callback {rate:g} Hz"]), 1.0 / rate)
    sensors = [
        {"type": "imu", "name": "imu", "body": "fore", "rate": 100},
        {"type": "odometry", "name": "odom", "body": "fore", "rate": 50, "publish_tf": False},
        {"type": "imu", "name": "slow_imu", "body": "upper", "rate": 30, "topic": "imu30"},
    ]

    def record(pub: Publication) -> None:
        stamp = pub.message.header.stamp  # type: ignore[attr-defined]
        steps[pub.topic].append(round(_stamp(stamp) * 1e-9 / 0.002))

    attach_sensors(world, sensors, record)
    world.step(60_000)
    rates = {"callback 100 Hz": 100, "callback 50 Hz": 50, "callback 30 Hz": 30}
    rates |= {"imu": 100, "odom": 50, "imu30": 30}
    assert set(steps) == set(rates)
    for name, rate in rates.items():
        per_second = np.bincount(np.array(steps[name]) // 500)[:120]
        assert set(per_second[1:].tolist()) == {rate}, name
        assert len(set(steps[name])) == len(steps[name]), name
        # tick k at the first step reaching k / rate (a sensor's tick 0 at the first step)
        grid = {math.ceil(k * 500 / rate) for k in range(rate * 120 + 1)}
        assert set(steps[name]) - {1} <= grid, name
    assert world.step_count == 60_000
    assert world.time == 60_000 * world.timestep  # the clock is steps x timestep, exactly
    world.reset()
    assert world.step_count == 0
    world.step(10)
    assert steps["callback 100 Hz"][-3:] == [60_000, 5, 10]  # back on the grid from t = 0


SPRING = robot(
    link("base", inertial(10.0, 0.1)),
    link("slider", inertial(2.0, 0.01)),
    joint("slide", "prismatic", "base", "slider",
          '<axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1000" velocity="10"/>'),
    name="spring",
)  # fmt: skip
STIFFNESS, MASS = 50.0, 2.0


@pytest.mark.filterwarnings("ignore:.*breaks the stability rule")  # undamped on purpose
def test_imu_acceleration_is_the_acceleration_at_its_stamp(tmp_path: Path) -> None:
    """A 2 kg slider on a 50 N/m spring drive (no damping): at stamp t the IMU must read
    -k x(t) / m with x(t) the position /joint_states gives for t. A one-step lag is
    k v dt / m, about 1e-2 m/s^2 here."""
    (tmp_path / "spring.urdf").write_text(SPRING)
    scene = {
        "physics": {"timestep": 0.002, "realtime_factor": 0, "integrator": "euler"},
        "robots": [{
            "urdf": "spring.urdf",
            "initial_positions": {"slide": 0.2},
            "armature": 0.0,  # no rotor inertia: the moving mass is the link's 2 kg
            "drives": {"default": {"stiffness": STIFFNESS, "damping": 0.0}},
        }],
    }  # fmt: skip
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump(scene))
    world = World.from_scene(load_scene(tmp_path / "scene.yaml"))
    positions: dict[int, tuple[float, float]] = {}
    world.add_step_callback(
        lambda w: positions.__setitem__(
            w.step_count, (w.joint_positions()["slide"], w.joint_velocities()["slide"])
        )
    )
    imu: list[Any] = []
    sensors = [{"type": "imu", "name": "imu", "body": "slider", "rate": 100}]
    attach_sensors(world, sensors, lambda pub: imu.append(pub.message))
    world.drives.set_position("slide", 0.0)
    world.step(1000)
    assert len(imu) == 201
    fastest = 0.0
    for msg in imu[1:]:
        x, v = positions[round(_stamp(msg.header.stamp) * 1e-9 / 0.002)]
        fastest = max(fastest, abs(v))
        expected = -STIFFNESS * x / MASS
        assert msg.linear_acceleration.x == pytest.approx(expected, abs=1e-9)
        assert msg.linear_acceleration.z == pytest.approx(9.81, abs=1e-9)
    assert fastest > 0.5  # moving: a lag would show


@pytest.mark.parametrize("integrator", ["euler", "implicit", "implicitfast", "rk4"])
def test_every_documented_integrator_builds(tmp_path: Path, integrator: str) -> None:
    world = arm_world(tmp_path, physics={"integrator": integrator})
    expected = {"euler": 0, "rk4": 1, "implicit": 2, "implicitfast": 3}[integrator]
    assert int(world.model.opt.integrator) == expected
    world.step(10)
