"""MuJoCo's small routines over many worlds at once, with MuJoCo's bits for each world.

The end-effector action of a single env calls `mj_jacBody` and the `mju_*` products and
Cholesky solve of `DampedLeastSquares` once per step. A vector env does the same for
all its worlds at once. Each element goes through the same IEEE operations in the same
order as MuJoCo's C code (`mj_jac`, `mju_dot`, `mju_mulMatMatT`, `mju_cholFactor`,
`mju_cholSolve`, `mju_mulMatTVec`), so each world gets the bits its single env gets;
`tests/gym/test_batch_math.py` checks that against MuJoCo. Two ways:

- NumPy, one operation per arithmetic step over every world (no BLAS, no fused
  multiply-add). The arrays put the worlds on the last axis ((3, cols, worlds) for
  Jacobians), so that every operation runs on contiguous rows: NumPy's cost for arrays
  this small is the call, and strided ones cost several times a contiguous one.
- MuJoCo's own routines on the worlds' systems side by side in one block-diagonal
  system (the least squares of a few worlds: a few C calls instead of dozens of NumPy
  ones).
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import GymError

__all__ = [
    "BLOCKED_UP_TO",
    "BLOCK_WORLDS",
    "BatchedDampedLeastSquares",
    "BodyJacobians",
    "mju_dot",
]

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

    def __call__(
        self,
        xpos: FloatArray,
        cdof: FloatArray,
        subtree_com: FloatArray,
        out: FloatArray | None = None,
    ) -> FloatArray:
        """(3, len(dofs), worlds) Jacobians from the (worlds, ...) fields, written into
        `out` when given (any strides: a solver's own work array)."""
        offset = (xpos[:, self.body] - subtree_com[:, self.root]).T.take(_OFFSET_ORDER, 0)
        factors = cdof[:, self.dofs].transpose(2, 1, 0).take(_CDOF_ORDER, 0)  # (9, dofs, n)
        products = factors[:6] * offset[:, None, :]
        jacobian: FloatArray = np.add(factors[6:], products[:3] - products[3:], out=out)
        if self._outside is not None:
            jacobian[:, self._outside] = 0.0
        return jacobian


BLOCK_WORLDS = 8
"""The worlds one block-diagonal system holds (`BatchedDampedLeastSquares`)."""
BLOCKED_UP_TO = 16
"""Up to this many worlds, the damped least squares runs on MuJoCo's routines over
block-diagonal systems of at most `BLOCK_WORLDS` worlds: a few C calls, where NumPy
needs dozens of calls over every world (it takes over beyond, where C's work on the
blocks' zeros outgrows NumPy's cost per call)."""


def _cholesky_solve(system: Iterable[FloatArray], error: Iterable[FloatArray]) -> list[FloatArray]:
    """x with (L L^T) x = error for many worlds, L the Cholesky factor of the symmetric 3x3
    `system` (its lower triangle: 00, 10, 20, 11, 21, 22), as `mju_cholFactor` (mindiag 0)
    and `mju_cholSolve` compute it."""
    g00, g10, g20, g11, g21, g22 = system
    e0, e1, e2 = error
    l00 = np.sqrt(g00)
    inverse = 1.0 / l00
    l10, l20 = g10 * inverse, g20 * inverse
    l11 = np.sqrt(g11 - (0.0 + l10 * l10))
    l21 = (g21 - (0.0 + l20 * l10)) * (1.0 / l11)
    l22 = np.sqrt(g22 - (0.0 + (l20 * l20 + l21 * l21)))
    y0 = e0 / l00
    y1 = (e1 - (0.0 + l10 * y0)) / l11
    y2 = (e2 - (0.0 + (l20 * y0 + l21 * y1))) / l22
    x2 = y2 / l22
    x1 = (y1 - l21 * x2) / l11
    x0 = ((y0 - l20 * x2) - l10 * x1) / l00
    return [x0, x1, x2]


class _Block:
    """`DampedLeastSquares.solve` of `count` worlds as one system: world b's rows of
    [J | damping I] are rows 3b..3b+2 of one matrix, so that MuJoCo's own routines give
    each world its bits. `mju_mulMatMatT` on those rows computes every pair of rows, each
    entry the dot of two rows as in one world's product; the pairs across worlds are then
    zeroed, which leaves the system block-diagonal: `mju_cholFactor` and `mju_cholSolve`
    then do each block's operations in its order, plus terms that are exact zeros (a
    block's dots have at most two other terms). Those zeros can only turn a zero of the
    solution into a zero of the other sign, which the last product does not see:
    `mju_mulMatTVec` over the block-diagonal [J | damping I] of every world starts each
    column's sum from +0 and adds the zeros of the other worlds' rows and then its world's
    three terms in order."""

    def __init__(self, cols: int, damping: float, count: int) -> None:
        width, rows = cols + 3, 3 * count
        self.cols, self.count = cols, count
        self.augmented = np.zeros((count, 3, width))  # world b's [J | damping I]
        for i in range(3):
            self.augmented[:, i, cols + i] = damping
        self._rows = self.augmented.reshape(rows, width)
        self.system = np.zeros((rows, rows))
        world = np.arange(rows) // 3
        # the lower triangle across worlds (all that the factorisation and solve read)
        self._across = np.flatnonzero(world[:, None] > world[None, :])
        self.error = np.zeros(rows)
        self.solution = np.zeros(rows)
        self.diagonal = np.zeros((rows, count * width))  # the block-diagonal [J | damping I]
        columns = np.arange(count)[:, None, None] * width + np.arange(width)
        self._blocks = np.ravel_multi_index(
            (np.repeat(np.arange(rows), width), np.repeat(columns, 3, axis=1).ravel()),
            self.diagonal.shape,
        )
        self.step = np.zeros(count * width)
        self._result = self.step.reshape(count, width)[:, :cols].T  # (cols, count), a view
        self.jacobian = self.augmented[:, :, :cols].transpose(1, 2, 0)
        """Where the Jacobians go, (3, cols, count): `solve` reads them there, no copy."""

    def solve(self, jacobian: FloatArray, error: NDArray[Any]) -> FloatArray:
        """(cols, count) joint steps for (3, cols, count) `jacobian` and (3, count) `error`
        (a view of a work array, valid until the next call)."""
        if jacobian is not self.jacobian:
            self.jacobian[...] = jacobian
        mujoco.mju_mulMatMatT(self.system, self._rows, self._rows)
        self.system.ravel()[self._across] = 0.0
        mujoco.mju_cholFactor(self.system, 0.0)
        self.error.reshape(self.count, 3)[...] = error.T
        mujoco.mju_cholSolve(self.solution, self.system, self.error)
        self.diagonal.ravel()[self._blocks] = self._rows.ravel()
        mujoco.mju_mulMatTVec(self.step, self.diagonal, self.solution)
        return self._result


class BatchedDampedLeastSquares:
    """`DampedLeastSquares` (dq = J^T (J J^T + damping^2 I)^-1 error) of many (3 x cols)
    Jacobians at once (a body's position task), with its bits for each world. Up to
    `BLOCKED_UP_TO` worlds it runs MuJoCo's routines on block-diagonal systems (`_Block`);
    beyond, NumPy over all worlds in `DampedLeastSquares.solve`'s order of operations:
    `mju_mulMatMatT` on [J | damping I], `mju_cholFactor` (lower factor L, each column
    scaled by the reciprocal of its diagonal), `mju_cholSolve` (forward, then backward
    substitution, later rows first; the dots of fewer than four terms added onto 0),
    `mju_mulMatTVec` (0 plus each row times its solution entry)."""

    def __init__(self, cols: int, damping: float) -> None:
        if damping <= 0:
            raise GymError(f"damping must be > 0 (the system is then definite), got {damping}")
        self.cols, self.damping = cols, damping
        self._augmented: dict[int, FloatArray] = {}
        self._blocks: dict[int, list[_Block]] = {}
        self._steps: dict[int, FloatArray] = {}

    def solve(self, jacobian: FloatArray, error: NDArray[Any]) -> FloatArray:
        """(cols, worlds) joint steps for (3, cols, worlds) `jacobian` and (3, worlds)
        `error` (any float type; possibly a view of a work array, valid until the next call)."""
        count = jacobian.shape[-1]
        if count <= BLOCKED_UP_TO:
            return self._solve_blocks(jacobian, error, count)
        cols = self.cols
        augmented = self._augmented.get(count)
        if augmented is None:  # [J | damping I] term by term, the damping part written once
            augmented = np.zeros((cols + 3, 3, count))
            for i in range(3):
                augmented[cols + i, i] = self.damping
            self._augmented[count] = augmented
        augmented[:cols] = jacobian.transpose(1, 0, 2)
        # mju_mulMatMatT: the lower triangle's dots (00, 10, 20, 11, 21, 22), term by term
        products = augmented.take(_LEFT, 1) * augmented.take(_RIGHT, 1)
        entries = mju_dot(products)  # g00, g10, g20, g11, g21, g22
        solution = np.array(_cholesky_solve(entries, error))
        # mju_mulMatTVec over the J part: the three products of each row in one multiplication
        terms = augmented[:cols] * solution  # (cols, 3, worlds)
        step: FloatArray = ((0.0 + terms[:, 0]) + terms[:, 1]) + terms[:, 2]
        return step

    def jacobian_buffer(self, count: int) -> FloatArray | None:
        """Where `solve` reads the Jacobians of `count` worlds from without copying them,
        (3, cols, count), when it has one such place (one block), else None."""
        blocks = self._blocks_for(count) if count <= BLOCKED_UP_TO else []
        return blocks[0].jacobian if len(blocks) == 1 else None

    def _blocks_for(self, count: int) -> list[_Block]:
        """The blocks that solve `count` worlds, made on first use."""
        blocks = self._blocks.get(count)
        if blocks is None:
            sizes = [len(part) for part in np.array_split(range(count), -(-count // BLOCK_WORLDS))]
            blocks = self._blocks[count] = [_Block(self.cols, self.damping, n) for n in sizes]
            self._steps[count] = np.zeros((self.cols, count))
        return blocks

    def _solve_blocks(self, jacobian: FloatArray, error: NDArray[Any], count: int) -> FloatArray:
        """`solve` on blocks of at most `BLOCK_WORLDS` worlds."""
        blocks = self._blocks_for(count)
        if len(blocks) == 1:
            return blocks[0].solve(jacobian, error)
        step, start = self._steps[count], 0
        for block in blocks:
            end = start + block.count
            step[:, start:end] = block.solve(jacobian[..., start:end], error[:, start:end])
            start = end
        return step
