"""Action adapters' numerics: the damped least-squares step against NumPy's solve."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from simbridge.gym.actions import DampedLeastSquares, damped_least_squares

_ENTRIES = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)


@settings(max_examples=200, deadline=None)
@given(arrays(np.float64, (3, 6), elements=_ENTRIES), arrays(np.float64, 3, elements=_ENTRIES))
def test_damped_least_squares_is_the_regularised_solution(
    jacobian: np.ndarray, error: np.ndarray
) -> None:
    damping = 0.05
    expected = jacobian.T @ np.linalg.solve(jacobian @ jacobian.T + damping**2 * np.eye(3), error)
    np.testing.assert_allclose(
        damped_least_squares(jacobian, error, damping), expected, rtol=1e-9, atol=1e-9
    )


def test_solver_reuses_its_arrays_and_takes_any_layout() -> None:
    rng = np.random.default_rng(0)
    solver = DampedLeastSquares(3, 6, 0.1)
    wide = rng.uniform(-1, 1, (3, 8))
    for _ in range(3):
        error = rng.uniform(-0.02, 0.02, 3)
        step = np.array(solver.solve(wide[:, 1:7], error))  # a strided view
        jac = wide[:, 1:7]
        expected = jac.T @ np.linalg.solve(jac @ jac.T + 0.01 * np.eye(3), error)
        np.testing.assert_allclose(step, expected, rtol=1e-9, atol=1e-12)
