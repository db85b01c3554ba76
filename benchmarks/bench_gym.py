"""Learning environments: Reach-v0 speed against the bare MuJoCo ceiling, and ARS learning it.

Speed: env steps per second of Reach-v0 alone, in a `SceneVectorEnv` of 8 and 32 worlds,
and with camera observations (84x84, 128x128), beside `mujoco.mj_step` on the same model
in the same state (the ceiling), each the best of three short rounds taken in turn.
`of_ceiling` compares physics steps (env steps x frame_skip) with the ceiling.
The single env is what `gymnasium.make` returns, its default wrappers (TimeLimit,
OrderEnforcing, PassiveEnvChecker) included.

Learning: augmented random search (NumPy, a linear policy reading "goal_delta") on a
vector of 16 Reach-v0 worlds until a 32-episode evaluation reaches 90% success or the
time budget runs out; the curve is printed as a table.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import simbridge.gym  # noqa: F401 - registers the ids
from simbridge.gym import ARSConfig, SceneEnv, train_ars

ENV_ID = "simbridge/Reach-v0"
ROUND_S = 1.5
ROUNDS = 3
LEARNING_BUDGET_S = 300.0


def _rate(step: Callable[[], None], per_call: int) -> float:
    """Calls of `step` per second over ROUND_S, times `per_call`."""
    step()
    start, calls = time.perf_counter(), 0
    while time.perf_counter() - start < ROUND_S:
        step()
        calls += 1
    return calls * per_call / (time.perf_counter() - start)


def _single(image_size: tuple[int, int] | None = None) -> tuple[Callable[[], None], SceneEnv]:
    env = gym.make(ENV_ID, image_size=image_size)
    env.reset(seed=0)
    zero = np.zeros(3, np.float32)
    unwrapped = env.unwrapped
    assert isinstance(unwrapped, SceneEnv)

    def step() -> None:
        _, _, terminated, truncated, _ = env.step(zero)
        if terminated or truncated:
            env.reset()

    return step, unwrapped


def _vector(num_envs: int) -> Callable[[], None]:
    vec = gym.make_vec(ENV_ID, num_envs=num_envs)
    vec.reset(seed=0)
    zero = np.zeros((num_envs, 3), np.float32)
    return lambda: vec.step(zero) and None


def speed_rows() -> list[dict[str, Any]]:
    """The speed table."""
    single, env = _single()
    skip = env.frame_skip
    ceiling_world = env.world.clone()
    model, data = ceiling_world.model, ceiling_world.data

    def bare() -> None:
        mujoco.mj_step(model, data, nstep=1000)

    cases: dict[str, tuple[Callable[[], None], int]] = {
        "mj_step, same model and state (ceiling)": (bare, 1000),
        "Reach-v0, single env": (single, 1),
    }
    for n in (8, 32):
        cases[f"Reach-v0, SceneVectorEnv of {n}"] = (_vector(n), n)
    for size in (84, 128):
        camera_step, _ = _single((size, size))
        cases[f"Reach-v0 + {size}x{size} camera obs"] = (camera_step, 1)
    best = dict.fromkeys(cases, 0.0)
    for _ in range(ROUNDS):
        for name, (step, per_call) in cases.items():
            best[name] = max(best[name], _rate(step, per_call))
    ceiling = best["mj_step, same model and state (ceiling)"]
    single_rate = best["Reach-v0, single env"]
    rows = []
    for name, rate in best.items():
        is_ceiling = name.startswith("mj_step")
        physics = rate if is_ceiling else rate * skip
        rows.append(
            {
                "scenario": name,
                "env_steps_per_s": "" if is_ceiling else round(rate),
                "physics_steps_per_s": round(physics),
                "of_ceiling": round(physics / ceiling, 2),
                "x_single_env": "" if is_ceiling else round(rate / single_rate, 2),
            }
        )
    return rows


def learning_rows() -> list[dict[str, Any]]:
    """The ARS learning curve on Reach-v0."""
    config = ARSConfig(
        iterations=400,
        eval_every=5,
        eval_episodes=32,
        keys=("goal_delta",),
        target_success=0.9,
        time_budget_s=LEARNING_BUDGET_S,
    )
    vec = gym.make_vec(ENV_ID, num_envs=2 * config.directions, max_episode_steps=50)
    result = train_ars(vec, 50, config)
    vec.close()
    return [
        {
            "iteration": point.iteration,
            "env_steps": point.env_steps,
            "wall_s": round(point.wall_s, 1),
            "mean_return": round(point.mean_return, 2),
            "success_rate": point.success_rate,
        }
        for point in result.curve
    ]


def run() -> dict[str, list[dict[str, Any]]]:
    """Both tables, by title."""
    return {
        "Reach-v0 speed (frame_skip 10, 2 ms physics step)": speed_rows(),
        "ARS on Reach-v0 (linear policy, 16 worlds, target 90% success)": learning_rows(),
    }


if __name__ == "__main__":
    from benchmarks.table import format_table

    for title, table in run().items():
        print(f"\n{title}\n")
        print(format_table(table))
