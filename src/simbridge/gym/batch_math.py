"""MuJoCo's small routines over many worlds at once, in NumPy, with MuJoCo's bits.

The end-effector action of a single env calls `mj_jacBody` and the `mju_*` products and
Cholesky solve of `DampedLeastSquares` once per step. A vector env does the same for
all its worlds with one NumPy operation per arithmetic step over every world. Each
element goes through the same IEEE operations in the same order as MuJoCo's C code
(`mj_jac`, `mju_dot`, `mju_mulMatMatT`, `mju_cholFactor`, `mju_cholSolve`,
`mju_mulMatTVec`), and every operation is a separate NumPy ufunc (no BLAS, no fused
multiply-add), so each world gets the bits its single env gets;
`tests/gym/test_batch_math.py` checks that against MuJoCo.

The arrays here put the worlds on the last axis ((3, cols, worlds) for Jacobians), so
that every operation runs on contiguous rows: NumPy's cost for arrays this small is the
call, and strided ones cost several times a contiguous one.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import GymError

__all__ = ["SCALAR_WORLDS", "BatchedDampedLeastSquares", "BodyJacobians", "mju_dot"]

FloatArray = NDArray[np.float64]

# mju_cross(a, b) = (a1 b2 - a2 b1, a2 b0 - a0 b2, a0 b1 - a1 b0): the factors of the six
# products, so that one multiplication makes them all
_CDOF_ORDER = np.array([1, 2, 0, 2, 0, 1, 3, 4, 5])  # angular part twice, then linear part
_OFFSET_ORDER = np.array([2, 0, 1, 1, 2, 0])
# the row pairs of J J^T's lower triangle: (0, 0), (1, 0), (2, 0), (1, 1), (2, 1), (2, 2)
_LEFT, _RIGHT = np.array([0, 1, 2, 1, 2, 2]), np.array([0, 0, 0, 1, 1, 2])


def mju_dot(products: FloatArray) -> FloatArray:
    """Sums over the first axis of `products` (the terms a[i] * b[i]) in `mju_dot`'s order:
    blocks of four added lane by lane and reduced as (0 + 2) + (1 + 3) when there are
    four terms or more, the rest added left to right onto that (or onto 0)."""
    count = len(products)
    blocks = count // 4
    total: FloatArray
    if blocks:
        lanes = products[0:4]
        for block in range(1, blocks):
            lanes = lanes + products[4 * block : 4 * block + 4]
        pairs = lanes[0:2] + lanes[2:4]
        total = pairs[0] + pairs[1]
    else:
        total = np.zeros(products.shape[1:])
    rest = count - 4 * blocks
    if rest:
        tail = products[4 * blocks]
        for i in range(4 * blocks + 1, count):
            tail = tail + products[i]
        total = total + tail
    return total


class BodyJacobians:
    """`mj_jacBody`'s translational Jacobian of one body over some of its dofs, for many
    worlds from their `xpos`, `cdof` and `subtree_com` (what `mj_kinematics` and
    `mj_comPos` leave): column d is cdof_lin[d] + cdof_ang[d] x (xpos[body] -
    subtree_com[root]) for the dofs on the body's chain, 0 for the others."""

    def __init__(self, model: mujoco.MjModel, body: int, dofs: slice | list[int]) -> None:
        self.body = body
        self.root = int(model.body_rootid[body])
        self.dofs = dofs
        chain: set[int] = set()
        moving = body
        while moving and not model.body_dofnum[moving]:  # mj_jac skips fixed bodies
            moving = int(model.body_parentid[moving])
        if moving:
            dof = int(model.body_dofadr[moving] + model.body_dofnum[moving] - 1)
            while dof >= 0:
                chain.add(dof)
                dof = int(model.dof_parentid[dof])
        columns = range(model.nv)[dofs] if isinstance(dofs, slice) else dofs
        self._outside = [i for i, dof in enumerate(columns) if dof not in chain] or None

    def __call__(self, xpos: FloatArray, cdof: FloatArray, subtree_com: FloatArray) -> FloatArray:
        """(3, len(dofs), worlds) Jacobians from the (worlds, ...) fields."""
        offset = np.take((xpos[:, self.body] - subtree_com[:, self.root]).T, _OFFSET_ORDER, 0)
        factors = np.take(cdof[:, self.dofs].transpose(2, 1, 0), _CDOF_ORDER, 0)  # (9, dofs, n)
        products = factors[:6] * offset[:, None, :]
        jacobian: FloatArray = factors[6:] + (products[:3] - products[3:])
        if self._outside is not None:
            jacobian[:, self._outside] = 0.0
        return jacobian


SCALAR_WORLDS = 16
"""Up to this many worlds, the Cholesky solve runs on Python floats world by world: a
few dozen float operations per world cost less than as many NumPy calls."""


def _cholesky_solve(
    system: Iterable[Any], error: Iterable[Any], sqrt: Callable[[Any], Any]
) -> tuple[Any, Any, Any]:
    """x with (L L^T) x = error, L the Cholesky factor of the symmetric 3x3 `system` (its
    lower triangle: 00, 10, 20, 11, 21, 22), as `mju_cholFactor` (mindiag 0) and
    `mju_cholSolve` compute it: for floats (with `math.sqrt`) or for arrays of many
    worlds (with `np.sqrt`) alike."""
    g00, g10, g20, g11, g21, g22 = system
    e0, e1, e2 = error
    l00 = sqrt(g00)
    inverse = 1.0 / l00
    l10, l20 = g10 * inverse, g20 * inverse
    l11 = sqrt(g11 - (0.0 + l10 * l10))
    l21 = (g21 - (0.0 + l20 * l10)) * (1.0 / l11)
    l22 = sqrt(g22 - (0.0 + (l20 * l20 + l21 * l21)))
    y0 = e0 / l00
    y1 = (e1 - (0.0 + l10 * y0)) / l11
    y2 = (e2 - (0.0 + (l20 * y0 + l21 * y1))) / l22
    x2 = y2 / l22
    x1 = (y1 - l21 * x2) / l11
    x0 = ((y0 - l20 * x2) - l10 * x1) / l00
    return x0, x1, x2


class BatchedDampedLeastSquares:
    """`DampedLeastSquares` (dq = J^T (J J^T + damping^2 I)^-1 error) of many (3 x cols)
    Jacobians at once (a body's position task), in `DampedLeastSquares.solve`'s order of
    operations: `mju_mulMatMatT` on [J | damping I], `mju_cholFactor` (lower factor L,
    each column scaled by the reciprocal of its diagonal), `mju_cholSolve` (forward, then
    backward substitution, later rows first; the dots of fewer than four terms added onto
    0), `mju_mulMatTVec` (0 plus each row times its solution entry)."""

    def __init__(self, cols: int, damping: float) -> None:
        if damping <= 0:
            raise GymError(f"damping must be > 0 (the system is then definite), got {damping}")
        self.cols, self.damping = cols, damping
        self._augmented: dict[int, FloatArray] = {}

    def solve(self, jacobian: FloatArray, error: FloatArray) -> FloatArray:
        """(cols, worlds) joint steps for (3, cols, worlds) `jacobian` and (3, worlds)
        `error` (rows contiguous)."""
        cols, count = self.cols, jacobian.shape[-1]
        augmented = self._augmented.get(count)
        if augmented is None:  # [J | damping I] term by term, the damping part written once
            augmented = np.zeros((cols + 3, 3, count))
            for i in range(3):
                augmented[cols + i, i] = self.damping
            self._augmented[count] = augmented
        augmented[:cols] = jacobian.transpose(1, 0, 2)
        # mju_mulMatMatT: the lower triangle's dots (00, 10, 20, 11, 21, 22), term by term
        products = np.take(augmented, _LEFT, 1) * np.take(augmented, _RIGHT, 1)
        entries = mju_dot(products)  # g00, g10, g20, g11, g21, g22
        if count <= SCALAR_WORLDS:  # Python floats: the same IEEE operations, cheaper here
            pairs = zip(entries.T.tolist(), error.T.tolist(), strict=True)  # world by world
            solution = np.array([_cholesky_solve(g, e, math.sqrt) for g, e in pairs]).T
        else:
            solution = np.array(_cholesky_solve(entries, error, np.sqrt))
        # mju_mulMatTVec over the J part: the three products of each row in one multiplication
        terms = augmented[:cols] * solution  # (cols, 3, worlds)
        step: FloatArray = ((0.0 + terms[:, 0]) + terms[:, 1]) + terms[:, 2]
        return step
