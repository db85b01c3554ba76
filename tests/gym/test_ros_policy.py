"""Sim-to-ROS: a policy written against the gym env drives the ROS-connected sim unchanged."""

from __future__ import annotations

import math
from contextlib import ExitStack
from pathlib import Path

import gymnasium as gym
import numpy as np

import simbridge.gym  # noqa: F401 - registers the ids
from simbridge.connector import Connector
from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.gym import Observation, Policy, RosPolicyRunner, SceneEnv
from simbridge.gym.tasks import NAV_SCENE, REACH_SCENE
from simbridge.sim.runner import SimulationSession


def reach_policy(obs: Observation) -> np.ndarray:
    return np.clip(obs["goal_delta"], -0.02, 0.02)


def nav_policy(obs: Observation) -> np.ndarray:
    ahead, left = (float(v) for v in obs["goal_delta"])
    bearing = math.atan2(left, ahead)
    clear = float(np.min(obs["lidar"])) > 0.25
    speed = min(0.4, 0.8 * math.hypot(ahead, left)) if abs(bearing) < 0.6 and clear else 0.0
    return np.array([speed, np.clip(2.0 * bearing, -1.5, 1.5)], np.float32)


def _run(scene: Path, env: SceneEnv, policy: Policy, goal: np.ndarray, sim_s: float):
    with ExitStack() as stack:
        endpoint = stack.enter_context(EndpointThread(EndpointOptions(port=0)))
        address = f"127.0.0.1:{endpoint.port}"
        session = stack.enter_context(SimulationSession(scene, address, connect_timeout=5))
        connector = stack.enter_context(Connector("127.0.0.1", endpoint.port).connect(wait=5))
        runner = stack.enter_context(RosPolicyRunner(env, policy, connector, goal))
        assert connector.flush(5)
        assert session.connector is not None
        assert session.connector.flush(5)
        # barriers: the endpoint holds both sides' subscriptions before the sim runs
        connector.endpoint_stats()
        session.connector.endpoint_stats()
        session.run(duration=sim_s, realtime_factor=1.0)
        return session.world, runner


def test_reach_policy_drives_the_arm_over_ros() -> None:
    env = gym.make("simbridge/Reach-v0").unwrapped
    assert isinstance(env, SceneEnv)
    goal = np.array([0.22, 0.12, 0.2])
    world, runner = _run(REACH_SCENE, env, reach_policy, goal, 2.0)
    assert not runner.errors
    assert runner.steps >= 60, "one control step per /joint_states message (50 Hz)"
    tool = world.link_pose("tool_link").translation
    assert np.linalg.norm(tool - goal) < 0.02
    # The runner saw what the env computes for the ROS-side state (its mirror lags a tick).
    assert runner.last_observation is not None
    np.testing.assert_allclose(runner.last_observation["ee_pos"], tool, atol=5e-3)
    # The same policy in the env reaches the same kind of goal from its own start.
    obs, _ = env.reset(seed=0)
    for _ in range(50):
        obs, _, terminated, _, _ = env.step(reach_policy(obs))
        if terminated:
            break
    assert terminated


def test_nav_policy_drives_the_mobile_robot_over_ros_with_lidar() -> None:
    env = gym.make("simbridge/DiffDriveNav-v0").unwrapped
    assert isinstance(env, SceneEnv)
    goal = np.array([1.0, -0.8])
    world, runner = _run(NAV_SCENE, env, nav_policy, goal, 7.0)
    assert not runner.errors
    base = world.link_pose("base_link").translation
    assert np.linalg.norm(base[:2] - goal) < 0.25
    obs = runner.last_observation
    assert obs is not None
    assert obs["lidar"].shape == (360,)
    # Ranges came from /scan (the same Lidar2D), made finite as in the env.
    assert 0.1 < float(obs["lidar"].min()) < 8.0
    np.testing.assert_allclose(obs["pose"][:2], base[:2], atol=0.05)


def test_a_message_dispatched_after_close_publishes_nothing() -> None:
    """The dispatcher may run a callback it took before `close` unsubscribed: it must not
    publish on the unregistered command topic (which would be an error)."""
    env = gym.make("simbridge/Reach-v0").unwrapped
    assert isinstance(env, SceneEnv)
    with ExitStack() as stack:
        endpoint = stack.enter_context(EndpointThread(EndpointOptions(port=0)))
        connector = stack.enter_context(Connector("127.0.0.1", endpoint.port).connect(wait=5))
        runner = RosPolicyRunner(env, reach_policy, connector, np.array([0.22, 0.12, 0.2]))
        runner.start()
        msg = runner.registry.new(
            "sensor_msgs/JointState",
            name=list(env.world.drives.joints),
            position=[0.0] * len(env.world.drives.joints),
        )
        runner._on_joints(msg)  # while open: one control step, published
        assert runner.steps == 1
        assert not runner.errors
        runner.close()
        runner._on_joints(msg)  # a late dispatch
        assert runner.steps == 1
        assert not runner.errors
