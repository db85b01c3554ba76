"""Augmented random search: a short smoke run on Reach-v0 (a few hundred env steps)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import simbridge.gym  # noqa: F401 - registers the ids
from simbridge.errors import GymError
from simbridge.gym import ARSConfig, LinearPolicy, train_ars


def test_ars_smoke_run_updates_a_policy_that_acts_in_the_env() -> None:
    config = ARSConfig(
        directions=2, top=1, iterations=3, eval_every=3, eval_episodes=4, target_success=None
    )
    vec = gym.make_vec("simbridge/Reach-v0", num_envs=4, max_episode_steps=20)
    result = train_ars(vec, 20, config)
    vec.close()
    assert [p.iteration for p in result.curve] == [0, 3]
    assert 0 < result.curve[-1].env_steps <= 3 * 4 * 20
    assert all(0.0 <= p.success_rate <= 1.0 for p in result.curve)
    assert np.any(result.policy.weights != 0), "ARS never moved the policy"
    env = gym.make("simbridge/Reach-v0")
    obs, _ = env.reset(seed=0)
    action = result.policy(obs)
    assert env.action_space.contains(action)
    env.step(action)


def test_linear_policy_scales_to_the_action_space_and_tracks_statistics() -> None:
    env = gym.make("simbridge/Reach-v0")
    assert isinstance(env.observation_space, gym.spaces.Dict)
    assert isinstance(env.action_space, gym.spaces.Box)
    policy = LinearPolicy.zeros(env.observation_space, env.action_space, ("goal_delta",))
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(policy(obs), np.zeros(3, np.float32))  # the centre
    policy.weights[:, :3] = 100 * np.eye(3)
    assert np.allclose(np.abs(policy(obs)), 0.02)  # saturates at the bounds
    batch = np.random.default_rng(0).normal(2.0, 3.0, (5000, 3))
    policy.update_statistics(batch)
    np.testing.assert_allclose(policy.mean, 2.0, atol=0.15)
    np.testing.assert_allclose(np.sqrt(policy.var), 3.0, atol=0.15)
    with pytest.raises(GymError, match="not observed"):
        LinearPolicy.zeros(env.observation_space, env.action_space, ("lidar",))


def test_ars_needs_two_worlds_per_direction() -> None:
    vec = gym.make_vec("simbridge/Reach-v0", num_envs=3)
    with pytest.raises(GymError, match="needs a vector of 16"):
        train_ars(vec, 10, ARSConfig())
    vec.close()
