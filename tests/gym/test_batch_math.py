"""The vector env's NumPy versions of MuJoCo's routines give MuJoCo's bits, world by world."""

from __future__ import annotations

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import simbridge.gym  # noqa: F401 - registers the ids
from simbridge.errors import GymError
from simbridge.gym import SceneEnv
from simbridge.gym.actions import DampedLeastSquares
from simbridge.gym.batch_math import (
    BLOCK_WORLDS,
    BLOCKED_UP_TO,
    BatchedDampedLeastSquares,
    BodyJacobians,
    mju_dot,
)

_ENTRIES = st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False, width=64)


def _bits(array: np.ndarray) -> np.ndarray:
    """The raw bits, so that -0.0 and 0.0 differ too."""
    return np.ascontiguousarray(array, np.float64).view(np.int64)


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 13).flatmap(lambda n: arrays(np.float64, (2, n), elements=_ENTRIES)))
def test_mju_dot_adds_in_mujocos_order(vectors: np.ndarray) -> None:
    a, b = vectors
    expected = mujoco.mju_dot(a, b)
    got = mju_dot((a * b)[:, None])  # the terms on the first axis, one "world"
    assert _bits(got)[0] == _bits(np.array([expected]))[0]


@settings(max_examples=80, deadline=None)
@given(
    # few worlds solve on MuJoCo's routines, in one block or several, many on NumPy arrays
    st.tuples(
        st.integers(1, 8),
        st.sampled_from([1, 5, BLOCK_WORLDS, BLOCK_WORLDS + 3, BLOCKED_UP_TO + 3]),
    ).flatmap(
        lambda size: st.tuples(
            arrays(np.float64, (size[1], 3, size[0]), elements=_ENTRIES),
            arrays(np.float64, (size[1], 3), elements=st.sampled_from([0.0, -0.0, 0.02, -0.013])),
        )
    ),
    st.sampled_from([0.05, 0.1, 1e-3]),
)
def test_batched_least_squares_matches_the_mujoco_solve_bit_for_bit(
    case: tuple[np.ndarray, np.ndarray], damping: float
) -> None:
    jacobians, errors = case
    cols = jacobians.shape[2]
    one = DampedLeastSquares(3, cols, damping)
    expected = np.array([np.array(one.solve(j, e)) for j, e in zip(jacobians, errors, strict=True)])
    batched = BatchedDampedLeastSquares(cols, damping)
    got = batched.solve(
        np.ascontiguousarray(jacobians.transpose(1, 2, 0)), np.ascontiguousarray(errors.T)
    )
    np.testing.assert_array_equal(_bits(got.T), _bits(expected))


def test_batched_least_squares_needs_damping() -> None:
    with pytest.raises(GymError, match="damping"):
        BatchedDampedLeastSquares(6, 0.0)


@pytest.mark.parametrize(
    ("env_id", "body", "joints"),
    [
        ("simbridge/Reach-v0", "tool_link", [f"joint_{i}" for i in range(1, 7)]),
        # the fingers are not on the grasp point's chain: their columns are 0
        ("simbridge/PickAndPlace-v0", "grasp_link", ["joint_2", "left_finger_joint", "joint_5"]),
    ],
)
def test_body_jacobians_match_mj_jac_body_bit_for_bit(
    env_id: str, body: str, joints: list[str]
) -> None:
    env = gym.make(env_id).unwrapped
    assert isinstance(env, SceneEnv)
    model, rng = env.world.model, np.random.default_rng(5)
    body_id = model.body(body).id
    dofs = [int(model.joint(j).dofadr[0]) for j in joints]
    qposadr = [int(model.joint(j).qposadr[0]) for j in joints]
    count = 16
    fields: dict[str, list[np.ndarray]] = {name: [] for name in ("xpos", "cdof", "subtree_com")}
    expected = np.zeros((count, 3, len(dofs)))
    jacp = np.zeros((3, model.nv))
    for i in range(count):
        data = mujoco.MjData(model)
        data.qpos[qposadr] = rng.uniform(-1.0, 1.0, len(qposadr))
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_jacBody(model, data, jacp, None, body_id)
        expected[i] = jacp[:, dofs]
        for name, rows in fields.items():
            rows.append(np.array(getattr(data, name)))
    jacobians = BodyJacobians(model, body_id, dofs)
    got = jacobians(*(np.array(fields[name]) for name in ("xpos", "cdof", "subtree_com")))
    np.testing.assert_array_equal(_bits(got.transpose(2, 0, 1)), _bits(expected))
    if "left_finger_joint" in joints:
        assert not got[:, 1].any(), "a dof off the chain has a zero column"
    env.close()
