"""Differential-drive kinematics, dead reckoning, limits and the command timeout."""

from __future__ import annotations

import math
import time
from contextlib import ExitStack
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

import simbridge
from simbridge.connector import Connector
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, Node
from simbridge.errors import SimError
from simbridge.messages import default_registry
from simbridge.sim.control import DriveMode
from simbridge.sim.control.diff_drive import (
    DiffDriveConfig,
    DiffDriveController,
    DiffDriveKinematics,
    DiffDriveLimits,
    Pose2D,
)
from simbridge.sim.ros import SimRosBridge, measure_wheels
from simbridge.sim.scene import Scene, parse_scene
from simbridge.sim.world import World

REG = default_registry()
KIN = DiffDriveKinematics(wheel_radius=0.05, wheel_separation=0.23)
speeds = st.floats(-20.0, 20.0, allow_nan=False)


def test_wheel_speeds_golden_values() -> None:
    # straight at 0.5 m/s: both wheels 0.5 / 0.05 = 10 rad/s
    assert KIN.wheel_velocities(0.5, 0.0) == pytest.approx((10.0, 10.0))
    # turning in place at 1 rad/s: each wheel travels 0.115 m/s, i.e. 2.3 rad/s, opposite
    assert KIN.wheel_velocities(0.0, 1.0) == pytest.approx((-2.3, 2.3))
    # v = r (wl + wr) / 2, w = r (wr - wl) / L
    assert KIN.body_twist(4.0, 6.0) == pytest.approx((0.25, 0.05 * 2.0 / 0.23))


@given(speeds, speeds)
def test_twist_and_wheel_speeds_are_inverse(left: float, right: float) -> None:
    linear, angular = KIN.body_twist(left, right)
    assert KIN.wheel_velocities(linear, angular) == pytest.approx((left, right), abs=1e-9)


def test_dead_reckoning_straight_turn_and_quarter_circle() -> None:
    start = Pose2D()
    straight = KIN.integrate(start, 10.0, 10.0)  # 10 rad * 0.05 m = 0.5 m
    assert (straight.x, straight.y, straight.yaw) == pytest.approx((0.5, 0.0, 0.0))
    # in place: yaw = r (dr - dl) / L
    spin = KIN.integrate(start, -1.0, 1.0)
    assert (spin.x, spin.y, spin.yaw) == pytest.approx((0.0, 0.0, 0.1 / 0.23))
    # a quarter circle of radius R about (0, R): wheels travel (R -+ L/2) * pi/2
    radius = 1.0
    left = (radius - 0.115) * math.pi / 2 / 0.05
    right = (radius + 0.115) * math.pi / 2 / 0.05
    arc = KIN.integrate(start, left, right)
    assert (arc.x, arc.y, arc.yaw) == pytest.approx((1.0, 1.0, math.pi / 2))
    # split into many pieces it ends in the same place
    pose = start
    for _ in range(100):
        pose = KIN.integrate(pose, left / 100, right / 100)
    assert (pose.x, pose.y, pose.yaw) == pytest.approx((1.0, 1.0, math.pi / 2))


def test_velocity_limits_clamp_commands() -> None:
    fast = {"max_linear_acceleration": 100.0, "max_angular_acceleration": 100.0}
    limits = DiffDriveLimits(max_linear_velocity=0.4, max_angular_velocity=1.0, **fast)
    ctrl = DiffDriveController(KIN, limits)
    ctrl.update(0.0)
    ctrl.command(2.0, -5.0, 0.0)
    ctrl.update(0.2)
    assert ctrl.twist == pytest.approx((0.4, -1.0))


def test_acceleration_limit_ramps_the_output() -> None:
    ctrl = DiffDriveController(KIN, DiffDriveLimits(max_linear_acceleration=0.5))
    ctrl.update(0.0)
    ctrl.command(1.0, 0.0, 0.0)
    outputs = []
    for i in range(1, 6):
        ctrl.command(1.0, 0.0, i * 0.1)
        outputs.append(ctrl.update(i * 0.1))
    # 0.5 m/s^2 for 0.5 s reaches 0.25 m/s, i.e. 5 rad/s on both wheels
    assert [round(o[0], 9) for o in outputs] == pytest.approx([1.0, 2.0, 3.0, 4.0, 5.0])
    assert ctrl.twist == pytest.approx((0.25, 0.0))


def test_command_timeout_stops_the_base() -> None:
    ctrl = DiffDriveController(KIN, DiffDriveLimits(max_linear_acceleration=1000.0), 0.5)
    assert ctrl.timed_out(0.0)  # no command yet
    ctrl.update(0.0)
    ctrl.command(0.3, 0.0, 0.0)
    assert ctrl.update(0.4) == pytest.approx((6.0, 6.0))
    assert ctrl.update(0.5) == pytest.approx((6.0, 6.0))  # exactly the timeout: still on
    assert ctrl.timed_out(0.51)
    assert ctrl.update(0.51) == pytest.approx((0.0, 0.0))
    ctrl.command(0.1, 0.0, 0.6)  # a fresh command revives it
    assert ctrl.update(0.6) == pytest.approx((2.0, 2.0))
    ctrl.reset()
    assert ctrl.twist == (0.0, 0.0)
    assert ctrl.timed_out(0.6)


def test_bad_values_are_rejected_with_names() -> None:
    with pytest.raises(SimError, match="wheel_radius"):
        DiffDriveKinematics(0.0, 0.2)
    with pytest.raises(SimError, match="max_angular_acceleration"):
        DiffDriveLimits(max_angular_acceleration=-1.0)
    with pytest.raises(SimError, match="both 'w'"):
        DiffDriveConfig("w", "w")
    with pytest.raises(SimError, match="finite"):
        DiffDriveController(KIN).command(math.nan, 0.0, 0.0)


# --- the scene key and the /cmd_vel link, end to end through an endpoint --------------------

DIFFBOT = Path(simbridge.__file__).parent / "assets" / "robots" / "diffbot.urdf"
WHEEL_DRIVE = {"damping": 2.0, "force_limit": 2.0}
"""Velocity-drive gains that suit 0.2 kg wheels (the defaults are for arm joints)."""
DRIVE_KEYS = {"left": "left_wheel_joint", "right": "right_wheel_joint"}


def _scene(**drive: object) -> Scene:
    data = {
        "physics": {"realtime_factor": 0},
        "robots": [
            {
                "urdf": str(DIFFBOT),
                "fixed_base": False,
                "base": {"xyz": [0, 0, 0.05]},
                "drives": {
                    "joints": {
                        "left_wheel_joint": WHEEL_DRIVE,
                        "right_wheel_joint": WHEEL_DRIVE,
                        "caster_swivel_joint": {"mode": "none"},
                        "caster_wheel_joint": {"mode": "none"},
                    }
                },
            }
        ],
        "objects": [{"name": "floor", "type": "plane"}],
        "ros": {"diff_drive": {**DRIVE_KEYS, **drive}},
    }
    return parse_scene(data, DIFFBOT.parent)


def test_scene_key_parses_with_defaults_and_names_mistakes() -> None:
    config = _scene(max_linear_velocity=0.4).ros.diff_drive
    assert config == DiffDriveConfig(
        "left_wheel_joint", "right_wheel_joint", limits=DiffDriveLimits(max_linear_velocity=0.4)
    )
    assert parse_scene({}, DIFFBOT.parent).ros.diff_drive is None
    with pytest.raises(SimError, match=r"ros\.diff_drive: unknown key 'speed'"):
        _scene(speed=1)
    with pytest.raises(SimError, match=r"ros\.diff_drive: missing key 'right'"):
        parse_scene({"ros": {"diff_drive": {"left": "a"}}}, DIFFBOT.parent)
    with pytest.raises(SimError, match=r"ros\.diff_drive\.cmd_timeout: must be > 0"):
        _scene(cmd_timeout=0)


def test_wheels_are_measured_from_the_model() -> None:
    world = World.from_scene(_scene())
    kinematics = measure_wheels(world, "left_wheel_joint", "right_wheel_joint")
    assert kinematics.wheel_radius == pytest.approx(0.05)
    assert kinematics.wheel_separation == pytest.approx(0.23)
    with pytest.raises(SimError, match="no joint 'hub'"):
        measure_wheels(world, "hub", "right_wheel_joint")


def test_one_cmd_vel_moves_the_base_then_the_timeout_stops_it() -> None:
    world = World.from_scene(_scene(max_linear_acceleration=1.0))
    with ExitStack() as stack:
        endpoint = stack.enter_context(EndpointThread(EndpointOptions(port=0)))
        connector = stack.enter_context(Connector("127.0.0.1", endpoint.port).connect(wait=5))
        bridge = stack.enter_context(SimRosBridge(world, connector))
        link = bridge.diff_drive
        assert link is not None
        assert world.drives.spec("left_wheel_joint").mode is DriveMode.VELOCITY
        assert isinstance(endpoint.backend, LocalBus)
        node = stack.enter_context(Node(endpoint.backend, "/teleop"))
        assert connector.flush(5)
        connector.endpoint_stats()  # a barrier: the endpoint holds the /cmd_vel subscription
        cmd = node.advertise("/cmd_vel", "geometry_msgs/Twist")
        world.step(100)  # settle on the wheels and caster
        start = world.link_pose("base_link").translation.copy()
        forward = REG.new("geometry_msgs/Vector3", x=0.2, y=0.0, z=0.0)
        cmd.publish(REG.new("geometry_msgs/Twist", linear=forward))
        deadline = time.monotonic() + 5
        while link.controller.timed_out(world.time) and time.monotonic() < deadline:
            time.sleep(0.001)
            world.process_posted()
        assert not link.controller.timed_out(world.time), "the command never arrived"
        commanded_at = world.time
        world.step(1000)  # 2 s: ramp up 0.2 s, cruise until the 0.5 s timeout, brake 0.2 s
        moved = world.link_pose("base_link").translation - start
    # 0.02 m ramping up + 0.3 s * 0.2 m/s + 0.02 m braking = 0.1 m, straight ahead
    assert moved[0] == pytest.approx(0.1, abs=0.006)
    assert abs(moved[1]) < 0.002
    assert link.controller.timed_out(commanded_at + 0.51)
    wheels = world.joint_velocities(["left_wheel_joint", "right_wheel_joint"])
    assert max(abs(v) for v in wheels.values()) < 0.05
