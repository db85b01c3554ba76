"""The shipped tasks are solvable the intended way: a physics grasp, driving around a room."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import simbridge.gym  # noqa: F401 - registers the ids
from simbridge.gym import Observation, SceneEnv, WheelVelocity
from simbridge.gym.tasks import NAV_SCENE, NavTask


def _pick_and_place(seed: int, close_gripper: bool) -> tuple[bool, float]:
    """A scripted controller on the observation: above the cube, down, close, lift, over
    the target, down, open. Returns (success, cube-to-target distance)."""
    env = gym.make("simbridge/PickAndPlace-v0")
    obs, _ = env.reset(seed=seed)
    phase, held = 0, 0
    info: dict[str, object] = {}
    for _ in range(150):
        ee, cube, goal = obs["ee_pos"], obs["cube_pos"], obs["goal"]
        closed = -1.0 if close_gripper else 1.0
        target, grip = {
            0: (cube + np.array([0, 0, 0.06]), 1.0),
            1: (cube, 1.0),
            2: (ee, closed),
            3: (np.array([ee[0], ee[1], 0.1]), closed),
            4: (goal + np.array([0, 0, 0.07]), closed),
            5: (goal + np.array([0, 0, 0.003]), closed),
        }.get(phase, (ee, 1.0))
        error = target - ee
        if phase in (2, 6):
            held += 1
            phase, held = (phase + 1, 0) if held > 15 else (phase, held)
        elif np.linalg.norm(error) < (0.006 if phase in (1, 5) else 0.01):
            phase += 1
        action = np.append(np.clip(error, -0.02, 0.02), grip).astype(np.float32)
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    return bool(info["is_success"]), float(np.linalg.norm(obs["cube_pos"] - obs["goal"]))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pick_and_place_by_physics_grasp(seed: int) -> None:
    success, distance = _pick_and_place(seed, close_gripper=True)
    assert success
    assert distance < 0.02


def test_pick_and_place_without_closing_the_gripper_fails() -> None:
    success, distance = _pick_and_place(0, close_gripper=False)
    assert not success
    assert distance > 0.05, "the cube only moves when the fingers hold it"


def _drive(obs: Observation) -> np.ndarray:
    ahead, left = (float(v) for v in obs["goal_delta"])
    bearing = math.atan2(left, ahead)
    speed = min(0.5, math.hypot(ahead, left)) if abs(bearing) < 0.5 else 0.0
    return np.array([speed, np.clip(2.5 * bearing, -1.5, 1.5)], np.float32)


def test_nav_goal_seeking_succeeds_and_walls_end_episodes() -> None:
    env = gym.make("simbridge/DiffDriveNav-v0")
    wins = 0
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        for _ in range(400):
            obs, _, terminated, truncated, info = env.step(_drive(obs))
            if terminated or truncated:
                break
        wins += bool(info["is_success"])
    assert wins >= 2  # a box can stand between start and goal: no planning here
    env.reset(seed=0)
    for _ in range(400):  # straight ahead, whatever is there: a wall or box ends it
        obs, reward, terminated, truncated, info = env.step(np.array([0.5, 0.0], np.float32))
        if terminated or truncated:
            break
    assert terminated
    assert not info["is_success"]
    assert float(reward) < -0.9
    assert float(obs["lidar"].min()) < 0.4, "the lidar sees what the base ran into"


def test_nav_observation_is_the_odometry_and_lidar_reading() -> None:
    env = gym.make("simbridge/DiffDriveNav-v0").unwrapped
    assert isinstance(env, SceneEnv)
    obs, _ = env.reset(seed=4)
    base = env.world.link_pose("base_link")
    np.testing.assert_allclose(obs["pose"][:2], base.translation[:2], atol=1e-5)
    yaw = math.atan2(base.rotation[1, 0], base.rotation[0, 0])
    np.testing.assert_allclose(obs["pose"][2:], [math.cos(yaw), math.sin(yaw)], atol=1e-5)
    ahead, left = obs["goal_delta"]
    assert math.hypot(ahead, left) == pytest.approx(
        float(np.linalg.norm(obs["goal"] - base.translation[:2])), abs=1e-4
    )
    assert ((obs["lidar"] >= 0.0) & (obs["lidar"] <= 8.0)).all()


def test_wheel_velocity_actions_on_the_nav_scene() -> None:
    """An env of your own on a shipped scene: equal wheel speeds roll the base straight."""
    env = SceneEnv(NAV_SCENE, NavTask(), WheelVelocity("left_wheel_joint", "right_wheel_joint"))
    obs, _ = env.reset(seed=1)
    start, heading = obs["pose"][:2].copy(), obs["pose"][2:].copy()
    for _ in range(25):  # 0.5 s at 4 rad/s: about 0.1 m on 0.05 m wheels
        obs, *_ = env.step(np.array([4.0, 4.0], np.float32))
    travelled = obs["pose"][:2] - start
    assert 0.05 < float(np.linalg.norm(travelled)) < 0.12
    assert float(np.dot(travelled / np.linalg.norm(travelled), heading)) > 0.99
    assert obs["joint_pos"].shape == (2,)  # the wheels it drives are observed
    assert obs["joint_vel"] == pytest.approx([4.0, 4.0], abs=0.5)


def test_camera_images_in_a_vector_of_nav_envs() -> None:
    vec = gym.make_vec("simbridge/DiffDriveNav-v0", num_envs=2, image_size=(48, 64))
    obs, _ = vec.reset(seed=0)
    assert obs["image"].shape == (2, 48, 64, 3)
    obs, *_ = vec.step(np.zeros((2, 2), np.float32))
    assert obs["image"].std() > 5
    assert not np.array_equal(obs["image"][0], obs["image"][1]), "two robots, two views"
    vec.close()
