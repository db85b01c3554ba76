"""Vectorised envs: the in-process batch of worlds on one model, and Gymnasium's sync/async."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import simbridge.gym  # registers the ids
from simbridge.errors import GymError
from simbridge.gym import SceneEnv, SceneVectorEnv
from simbridge.gym.batch_math import BLOCK_WORLDS


def _actions(space: gym.Space[np.ndarray], steps: int, seed: int) -> list[np.ndarray]:
    space.seed(seed)
    return [space.sample() for _ in range(steps)]


# Reach alone takes the all-batched path; joint deltas batch the action too; the camera makes
# the worlds' data current every step; the others run their action and task world by world
_CASES: list[tuple[str, dict[str, Any]]] = [(env_id, {}) for env_id in simbridge.gym.ENV_IDS] + [
    ("simbridge/Reach-v0", {"action": "joint_delta"}),
    ("simbridge/Reach-v0", {"image_size": (12, 16)}),
]


@pytest.mark.parametrize(("env_id", "kwargs"), _CASES)
def test_batched_worlds_match_single_envs_bit_for_bit(env_id: str, kwargs: dict[str, Any]) -> None:
    vec = gym.make_vec(env_id, num_envs=3, **kwargs)
    assert isinstance(vec, SceneVectorEnv)
    assert len({id(w.model) for w in vec.worlds}) == 1, "one compiled model for every world"
    assert len({id(w.data) for w in vec.worlds}) == 3
    actions = _actions(vec.action_space, 15, 1)
    obs, info = vec.reset(seed=20)
    trace = [obs]
    outcomes = [info["is_success"]]
    for action in actions:
        obs, reward, terminated, truncated, info = vec.step(action)
        assert not (terminated.any())
        assert not (truncated.any())
        trace.append(obs)
        outcomes.append(np.stack([reward, info["is_success"]]))
    vec.close()
    for i in range(3):
        env = gym.make(env_id, **kwargs)
        obs, _ = env.reset(seed=20 + i)
        single = [obs]
        for t, action in enumerate(actions):
            obs, alone_reward, _, _, info = env.step(action[i])
            single.append(obs)
            np.testing.assert_array_equal(
                outcomes[t + 1][:, i],
                [alone_reward, info["is_success"]],
                err_msg=f"world {i} step {t}",
            )
        for t, (batched, alone) in enumerate(zip(trace, single, strict=True)):
            for key in alone:
                np.testing.assert_array_equal(
                    batched[key][i], alone[key], err_msg=f"world {i} step {t} {key}"
                )


def test_truncation_and_next_step_autoreset() -> None:
    vec = gym.make_vec("simbridge/Reach-v0", num_envs=2, max_episode_steps=3)
    first, _ = vec.reset(seed=7)
    zero = np.zeros((2, 3), np.float32)
    for _ in range(2):
        _, _, _, truncated, _ = vec.step(zero)
        assert not truncated.any()
    _, _, _, truncated, _ = vec.step(zero)
    assert truncated.all()
    obs, reward, terminated, truncated, _ = vec.step(zero)  # the autoreset step
    assert (reward == 0).all()
    assert not (terminated.any())
    assert not (truncated.any())
    assert not np.array_equal(obs["goal"], first["goal"]), "autoreset draws a new episode"
    vec.close()


def test_vector_rejects_wrong_action_shapes() -> None:
    vec = gym.make_vec("simbridge/Reach-v0", num_envs=2)
    vec.reset(seed=0)
    with pytest.raises(GymError, match="shape"):
        vec.step(np.zeros((3, 3), np.float32))
    with pytest.raises(GymError, match="finite"):
        vec.step(np.array([[0.0, 0.0, 0.0], [0.0, np.nan, 0.0]], np.float32))
    vec.close()


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_gymnasium_sync_and_async_vector_envs(mode: str) -> None:
    vec = gym.make_vec("simbridge/Reach-v0", num_envs=2, vectorization_mode=mode)
    obs, _ = vec.reset(seed=3)
    assert obs["ee_pos"].shape == (2, 3)
    for action in _actions(vec.action_space, 5, 0):
        obs, reward, _terminated, _truncated, _info = vec.step(action)
    assert reward.shape == (2,)
    assert obs["joint_pos"].shape == (2, 6)
    reference = gym.make_vec("simbridge/Reach-v0", num_envs=2)
    expected, _ = reference.reset(seed=3)
    for action in _actions(vec.action_space, 5, 0):
        expected, *_ = reference.step(action)
    np.testing.assert_allclose(obs["ee_pos"], expected["ee_pos"], atol=1e-4)
    reference.close()
    vec.close()


# one least-squares block of worlds, and two (`batch_math.BLOCK_WORLDS` per block)
@pytest.mark.parametrize("num_envs", [5, BLOCK_WORLDS + 3])
def test_physics_threads_do_not_change_the_results(num_envs: int) -> None:
    """The batch's thread count only spreads the worlds: 1 and 2 threads, same bits, and
    the last world (in the last block) has its single env's bits."""
    traces = []
    for threads in (1, 2):
        vec = gym.make_vec("simbridge/Reach-v0", num_envs=num_envs, threads=threads)
        actions = _actions(vec.action_space, 8, 2)
        obs, _ = vec.reset(seed=4)
        trace = [obs]
        for action in actions:
            obs, *_ = vec.step(action)
            trace.append(obs)
        vec.close()
        traces.append(trace)
    for t, (one, two) in enumerate(zip(*traces, strict=True)):
        for key in one:
            np.testing.assert_array_equal(one[key], two[key], err_msg=f"step {t} {key}")
    last = num_envs - 1
    env = gym.make("simbridge/Reach-v0")
    single = [env.reset(seed=4 + last)[0]] + [env.step(action[last])[0] for action in actions]
    for t, (batched, alone) in enumerate(zip(traces[0], single, strict=True)):
        for key in alone:
            np.testing.assert_array_equal(batched[key][last], alone[key], err_msg=f"{t} {key}")


def test_vector_rejects_bad_thread_counts_and_episode_lengths() -> None:
    with pytest.raises(GymError, match="threads"):
        gym.make_vec("simbridge/Reach-v0", num_envs=2, threads=-1)
    with pytest.raises(GymError, match="max_episode_steps"):
        gym.make_vec("simbridge/Reach-v0", num_envs=2, max_episode_steps=0)


def test_worlds_ending_apart_match_single_envs_across_autoresets() -> None:
    """World 0 heads for its goal and ends early; the others keep stepping meanwhile (the
    vector steps some worlds and resets one), and every world still matches its single
    env, which resets on the step after its episode ended, as Gymnasium's next-step
    autoreset does."""
    count, steps = 3, 40
    vec = gym.make_vec("simbridge/Reach-v0", num_envs=count)
    singles = [gym.make("simbridge/Reach-v0").unwrapped for _ in range(count)]
    obs, _ = vec.reset(seed=30)
    alone = [env.reset(seed=30 + i)[0] for i, env in enumerate(singles)]
    ended = [False] * count
    resets = 0
    for t in range(steps):
        action = np.zeros((count, 3), np.float32)
        action[0] = np.clip(obs["goal_delta"][0], -0.02, 0.02)  # greedy: ends early
        action[1] = 0.01 * np.sin(t)
        obs, reward, terminated, _, _ = vec.step(action)
        for i, env in enumerate(singles):
            if ended[i]:
                alone[i], _ = env.reset()
                single_reward, single_terminated = 0.0, False
                resets += 1
            else:
                alone[i], stepped_reward, single_terminated, _, _ = env.step(action[i])
                single_reward = float(stepped_reward)
            ended[i] = single_terminated
            assert reward[i] == single_reward, f"world {i} step {t}"
            assert terminated[i] == single_terminated, f"world {i} step {t}"
            for key, value in alone[i].items():
                np.testing.assert_array_equal(obs[key][i], value, err_msg=f"{i} {t} {key}")
    assert resets >= 1, "world 0 never reached its goal: the test stepped no partial batch"
    vec.close()


def test_worlds_read_after_batched_steps_hold_the_single_envs_state() -> None:
    """Reach's steps leave the worlds' own data alone; reading `worlds` brings it up to date:
    state, poses, drive targets and controls as the single env's after the same steps."""
    vec = gym.make_vec("simbridge/Reach-v0", num_envs=2)
    assert isinstance(vec, SceneVectorEnv)
    singles = [gym.make("simbridge/Reach-v0").unwrapped for _ in range(2)]
    assert all(isinstance(env, SceneEnv) for env in singles)
    vec.reset(seed=40)
    for i, env in enumerate(singles):
        env.reset(seed=40 + i)
    for action in _actions(vec.action_space, 6, 3):
        vec.step(action)
        for env, row in zip(singles, action, strict=True):
            env.step(row)
    joints = [f"joint_{i}" for i in range(1, 7)]
    for world, env in zip(vec.worlds, singles, strict=True):
        assert isinstance(env, SceneEnv)
        alone = env.world
        for field in ("qpos", "qvel", "ctrl", "xpos", "xquat", "cvel", "qacc_warmstart"):
            np.testing.assert_array_equal(
                getattr(world.data, field), getattr(alone.data, field), err_msg=field
            )
        assert world.time == alone.time
        for joint in joints:
            assert world.drives.target(joint) == alone.drives.target(joint), joint
    frames = vec.render()
    assert frames is None, "no render mode: no frames"
    vec.close()


def test_vector_renders_the_worlds_as_their_single_envs_do() -> None:
    vec = gym.make_vec("simbridge/Reach-v0", num_envs=2, render_mode="rgb_array")
    single = gym.make("simbridge/Reach-v0", render_mode="rgb_array")
    vec.reset(seed=50)
    single.reset(seed=51)
    for action in _actions(vec.action_space, 4, 5):
        vec.step(action)
        single.step(action[1])
    frames = vec.render()
    assert frames is not None
    np.testing.assert_array_equal(frames[1], single.render())
    vec.close()
    single.close()
