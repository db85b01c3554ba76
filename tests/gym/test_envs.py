"""The registered environments: Gymnasium's checker, seeding, determinism, rendering, errors."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import simbridge.gym
from simbridge.errors import GymError
from simbridge.gym import SceneEnv


@pytest.mark.parametrize("env_id", simbridge.gym.ENV_IDS)
def test_check_env_passes(env_id: str) -> None:
    env = gym.make(env_id, render_mode="rgb_array")
    check_env(env.unwrapped, skip_render_check=False)
    env.reset(seed=0)
    frame = env.render()
    assert isinstance(frame, np.ndarray)
    assert frame is not None
    assert frame.dtype == np.uint8
    assert frame.shape == (480, 640, 3)
    assert frame.std() > 5, "the rendered frame is blank"
    env.close()


def _rollout(env_id: str, seed: int, steps: int) -> list[dict[str, np.ndarray]]:
    env = gym.make(env_id)
    env.action_space.seed(seed)
    obs, _ = env.reset(seed=seed)
    trace = [obs]
    for _ in range(steps):
        obs, *_ = env.step(env.action_space.sample())
        trace.append(obs)
    env.close()
    return trace


@pytest.mark.parametrize("env_id", simbridge.gym.ENV_IDS)
def test_same_seed_same_run_bit_for_bit(env_id: str) -> None:
    first, second = _rollout(env_id, 3, 25), _rollout(env_id, 3, 25)
    for a, b in zip(first, second, strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    other = _rollout(env_id, 4, 0)
    assert not np.array_equal(first[0]["goal"], other[0]["goal"]), "seed does not change goal"


def test_reset_seed_restarts_the_same_episode_in_one_env() -> None:
    env = gym.make("simbridge/Reach-v0")
    first, _ = env.reset(seed=11)
    for _ in range(5):
        env.step(env.action_space.sample())
    again, _ = env.reset(seed=11)
    for key in first:
        np.testing.assert_array_equal(first[key], again[key])


def test_reach_greedy_policy_succeeds_and_episode_terminates() -> None:
    env = gym.make("simbridge/Reach-v0")
    obs, info = env.reset(seed=5)
    assert not info["is_success"]
    for _ in range(50):
        action = np.clip(obs["goal"] - obs["ee_pos"], -0.02, 0.02)
        obs, reward, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    assert terminated
    assert info["is_success"]
    assert np.linalg.norm(obs["goal"] - obs["ee_pos"]) < 0.02
    assert -0.02 < float(reward) <= 0


def test_reach_joint_delta_actions_move_the_drive_targets() -> None:
    env = gym.make("simbridge/Reach-v0", action="joint_delta").unwrapped
    assert isinstance(env, SceneEnv)
    env.reset(seed=0)
    before = env.world.drives.target("joint_1").position
    env.step(np.array([0.05, 0, 0, 0, 0, 0], np.float32))
    assert env.world.drives.target("joint_1").position == pytest.approx(before + 0.05)
    for _ in range(10):
        obs, *_ = env.step(np.zeros(6, np.float32))
    assert obs["joint_pos"][0] == pytest.approx(before + 0.05, abs=2e-3)


def test_actions_are_clipped_and_bad_actions_rejected() -> None:
    env = gym.make("simbridge/Reach-v0").unwrapped
    assert isinstance(env, SceneEnv)
    env.reset(seed=0)
    start = env.observe()["ee_pos"].copy()
    env.step(np.array([1.0, 0.0, 0.0], np.float32))  # clipped to 0.02 m
    moved = env.observe()["ee_pos"] - start
    assert 0.005 < moved[0] < 0.03
    with pytest.raises(GymError, match="shape"):
        env.step(np.zeros(4, np.float32))
    with pytest.raises(GymError, match="finite"):
        env.step(np.array([np.nan, 0, 0], np.float32))
    with pytest.raises(GymError, match="Reach action"):
        gym.make("simbridge/Reach-v0", action="torque")


def test_camera_observation_from_the_sensor_code() -> None:
    env = gym.make("simbridge/Reach-v0", image_size=(84, 84))
    obs, _ = env.reset(seed=0)
    image = obs["image"]
    assert image.shape == (84, 84, 3)
    assert image.dtype == np.uint8
    assert isinstance(env.observation_space, gym.spaces.Dict)
    assert env.observation_space["image"].contains(image)
    assert image.std() > 5
    env.close()
