"""Augmented random search: a short smoke run on Reach-v0 (a few hundred env steps), and
rollouts split over several vectors learning what one vector learns."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import simbridge.gym  # noqa: F401 - registers the ids
from simbridge.errors import GymError
from simbridge.gym import ARSConfig, LinearPolicy, train_ars
from simbridge.gym.ars import Episodes, VectorRollouts, learn_ars, noise_table


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


class _SplitRollouts:
    """Rollouts on two vector envs of their own (as two workers would run them), joined."""

    def __init__(self, table: np.ndarray, split: tuple[int, int], max_steps: int) -> None:
        self.split = split
        self.parts = [
            VectorRollouts(
                gym.make_vec("simbridge/Reach-v0", num_envs=2 * n, max_episode_steps=max_steps),
                max_steps,
                table,
            )
            for n in split
        ]

    def perturbed(self, policy, noise, offsets, seeds):  # type: ignore[no-untyped-def]
        n, first, parts = len(offsets), 0, []
        for worker, count in zip(self.parts, self.split, strict=True):
            part = worker.perturbed(
                policy, noise, offsets[first : first + count], seeds[first : first + count]
            )
            columns = [*range(first, first + count), *range(n + first, n + first + count)]
            parts.append((part, columns))
            first += count
        return Episodes.join(parts, 2 * n)

    def evaluate(self, policy, seeds):  # type: ignore[no-untyped-def]
        cut = len(seeds) // 3
        return Episodes.join(
            [
                (self.parts[0].evaluate(policy, seeds[:cut]), range(cut)),
                (self.parts[1].evaluate(policy, seeds[cut:]), range(cut, len(seeds))),
            ],
            len(seeds),
        )


def test_rollouts_split_over_two_vectors_learn_bit_for_bit_what_one_vector_learns() -> None:
    config = ARSConfig(
        directions=4, top=2, iterations=4, eval_every=2, eval_episodes=5, target_success=None
    )
    vec = gym.make_vec("simbridge/Reach-v0", num_envs=8, max_episode_steps=25)
    one = train_ars(vec, 25, config)
    table = noise_table(config)
    split = _SplitRollouts(table, (3, 1), 25)
    assert isinstance(vec.single_observation_space, gym.spaces.Dict)
    assert isinstance(vec.single_action_space, gym.spaces.Box)
    start = LinearPolicy.zeros(vec.single_observation_space, vec.single_action_space)
    two = learn_ars(split, start, table, config)
    vec.close()
    assert [asdict(p) | {"wall_s": 0} for p in two.curve] == [
        asdict(p) | {"wall_s": 0} for p in one.curve
    ]
    np.testing.assert_array_equal(two.policy.weights, one.policy.weights)
    np.testing.assert_array_equal(two.policy.mean, one.policy.mean)
    np.testing.assert_array_equal(two.policy.var, one.policy.var)
    assert two.policy.count == one.policy.count


def test_join_puts_features_in_one_vectors_order_and_checks_coverage() -> None:
    a = Episodes(
        np.array([1.0, 2.0]),
        np.array([True, False]),
        3,
        np.array([[True, True], [False, True]]),
        np.array([[10.0], [11.0], [12.0]]),  # (t0, w0), (t0, w1), (t1, w1)
    )
    b = Episodes(np.array([3.0]), np.array([True]), 1, np.array([[True]]), np.array([[20.0]]))
    joined = Episodes.join([(a, [0, 2]), (b, [1])], 3)  # worlds 0 and 2 from a, 1 from b
    np.testing.assert_array_equal(joined.returns, [1.0, 3.0, 2.0])
    np.testing.assert_array_equal(joined.successes, [True, True, False])
    assert joined.steps == 4
    assert joined.features is not None
    np.testing.assert_array_equal(joined.features.ravel(), [10.0, 20.0, 11.0, 12.0])
    with pytest.raises(GymError, match="not once each"):
        Episodes.join([(a, [0, 1]), (b, [1])], 3)


def test_policy_saves_and_loads(tmp_path: Path) -> None:
    env = gym.make("simbridge/Reach-v0")
    assert isinstance(env.observation_space, gym.spaces.Dict)
    assert isinstance(env.action_space, gym.spaces.Box)
    policy = LinearPolicy.zeros(env.observation_space, env.action_space, ("goal_delta", "ee_pos"))
    policy.weights = np.random.default_rng(1).normal(size=policy.weights.shape)
    policy.update_statistics(np.random.default_rng(2).normal(size=(10, 6)))
    policy.save(tmp_path / "p.npz")
    loaded = LinearPolicy.load(tmp_path / "p.npz")
    assert loaded.keys == policy.keys
    for name in ("weights", "low", "high", "mean", "var"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(policy, name))
    assert loaded.count == policy.count
    obs, _ = env.reset(seed=3)
    np.testing.assert_array_equal(loaded(obs), policy(obs))
    (tmp_path / "bad.npz").write_bytes(b"not a policy")
    with pytest.raises(GymError, match=r"bad\.npz: not a policy"):
        LinearPolicy.load(tmp_path / "bad.npz")
