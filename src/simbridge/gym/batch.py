"""`WorldBatch`: every world of a vector env as (num_envs, ...) arrays, one row per world.

The physics of `SceneVectorEnv` lives in the rows of a `mujoco.batch.Batch`. Batched task
and action code (`Task.evaluate_many`, `ActionAdapter.apply_many`) reads and writes those
rows and the derived fields the batch computes (its own output arrays: no copies), all
worlds at once, instead of each world's own `MjData`. When every part of a step is
batched, the vector env leaves the worlds' data behind between resets and brings a world
up to date (`store`) only when something reads it (rendering, `SceneVectorEnv.worlds`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import mujoco
import numpy as np
from mujoco.batch import Batch
from numpy.typing import NDArray

from simbridge.sim.control.drive_bank import Actuators
from simbridge.sim.world import World

__all__ = ["STAGE", "WorldBatch"]

FloatArray = NDArray[np.float64]

STAGE = int(mujoco.mjtStage.mjSTAGE_VEL)
"""What the batch computes after its steps: poses, Jacobians and body velocities (as a
single env's `SceneEnv.refresh`), and the rest that the next step's first substep starts
from in a persistent batch, so that it costs nothing extra."""


class WorldBatch:
    """Row i of every array is world i: state fields live (views of the batch's rows),
    derived fields as the batch's last call on each row left them, drive position
    targets kept here.

    - `qpos`, `qvel`, `ctrl`: views of the state rows; a write to `ctrl` is the world's
      control for its next physics steps.
    - `batch[name]`: the derived `MjData` field `name` (one of `fields`, e.g. "xpos"),
      up to date with the state as a single env's data is after its step (`refresh`).
    - `positions`: every drive's position target (as `DriveBank` keeps them), set by
      a reset and by `set_positions` (batched adapters; the others aim the worlds' own
      drives).
    - `worlds`: the worlds themselves, whose data is current only where the vector env
      runs per-world code (a task or an action adapter without a batched form).
    """

    def __init__(self, batch: Batch, worlds: Sequence[World], fields: Iterable[str]) -> None:
        first = worlds[0]
        self.model = first.model
        self.worlds = list(worlds)
        self.size = len(self.worlds)
        self.spec = int(mujoco.mjtState.mjSTATE_INTEGRATION)
        self.state = batch.state
        self.qpos = batch.bind("qpos")
        self.qvel = batch.bind("qvel")
        self.ctrl = batch.bind("ctrl")
        self.positions = np.zeros((self.size, self.model.nu))
        self._rows = list(self.state)  # each world's state row, a view
        self._batch = batch
        # bound now: the batch fills an output from its next call on
        self._fields: dict[str, FloatArray] = {
            name: batch.bind(name) for name in sorted(set(fields))
        }
        self._drives = first.drives  # the drive law: one model, the same gains and limits
        self._aimed = np.zeros(self.model.nu, np.bool_)
        """Actuators `set_positions` aimed, whose targets `store` hands to the worlds' drives."""
        self._all = slice(0, self.model.nu)

    def __getitem__(self, name: str) -> FloatArray:
        """Derived field `name` of every world, (size, ...) (read it, do not write)."""
        return self._fields[name]

    @property
    def fields(self) -> tuple[str, ...]:
        """The derived fields kept."""
        return tuple(self._fields)

    def set_positions(self, actuators: Actuators, positions: FloatArray) -> None:
        """`DriveBank.set_positions` of every world at once: `positions` is (size, k) for
        the k `actuators`; the rows' `ctrl` gets the same bits the drives would write."""
        if isinstance(actuators, slice):  # columns of views: written in place
            self._drives.position_controls_into(
                actuators, positions, self.positions[:, actuators], self.ctrl[:, actuators]
            )
        else:
            clamped, ctrl = self._drives.position_controls(actuators, positions)
            self.positions[:, actuators] = clamped
            self.ctrl[:, actuators] = ctrl
        self._aimed[actuators] = True

    def load(self, row: int) -> None:
        """Row `row` from its world's data (after a reset there): state and drive targets
        (`derive` then brings its derived fields up to date)."""
        world = self.worlds[row]
        mujoco.mj_getState(self.model, world.data, self._rows[row], self.spec)
        self.positions[row] = world.drives.positions(self._all)

    def derive(self, rows: list[int]) -> None:
        """The derived fields of `rows` (sorted) from their state, after `load`: poses,
        Jacobians and velocities (`mjSTAGE_VEL`, which their next step starts from)."""
        if self._fields and rows:
            ids = None if len(rows) == self.size else np.array(rows, np.int32)
            self._batch.forward(ids, stage=STAGE)

    def store(self, row: int) -> None:
        """World `row`'s data from its row: the state, and the targets of the drives that
        `set_positions` aimed (derived fields are the caller's: `SceneEnv.refresh`)."""
        world = self.worlds[row]
        mujoco.mj_setState(self.model, world.data, self._rows[row], self.spec)
        if self._aimed.any():
            aimed = np.flatnonzero(self._aimed)
            world.drives.set_positions(aimed, self.positions[row, aimed])

    def save(self, row: int) -> None:
        """Row `row`'s state from its world's data, after per-world code (an action adapter
        without a batched form, whose targets stay in the world's drives) changed it."""
        world = self.worlds[row]
        mujoco.mj_getState(self.model, world.data, self._rows[row], self.spec)
