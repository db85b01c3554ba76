"""A compiled scene's MuJoCo state: read joints and links, teleport joints, restore time 0.

This is the part of a `World` that knows what the simulation looks like now; stepping it
and its callbacks are `World`'s, reaching it from other threads `CrossThreadControl`'s.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import SimError
from simbridge.sim.control.drive_bank import DriveBank
from simbridge.sim.scene.builder import BuiltScene
from simbridge.sim.scene.spec import Scene
from simbridge.sim.urdf.transforms import Transform
from simbridge.sim.world.robot import RobotHandle

__all__ = ["WorldState"]


class WorldState:
    """A MuJoCo model built from a `Scene` and its data: joint and link state, drives.

    `model` may be given to share one compiled model between worlds (`World.clone`).
    """

    def __init__(self, built: BuiltScene, model: mujoco.MjModel | None = None) -> None:
        self.built = built
        """The scene as built into MJCF (robots, drives, the document)."""
        self.scene: Scene = built.scene
        self.document = built.document
        self.model: mujoco.MjModel = built.document.compile() if model is None else model
        self.data = mujoco.MjData(self.model)
        self.robots = {r.name: RobotHandle(r, self.model) for r in built.robots}
        self._slot_table = {
            n: (n, s.qpos, s.dof) for r in self.robots.values() for n, s in r.joints.items()
        }
        self._all_slots = list(self._slot_table.values())
        self._body_ids: dict[str, int] = {}
        specs = {name: spec for r in built.robots for name, spec in r.drives.items()}
        self.drives = DriveBank(self.model, self.data, specs)
        self._rng: np.random.Generator | None = None
        self._steps = 0
        self._derived_stale = False
        self._state_stale = False
        """Poses, velocity terms and actuator forces lag the state (`refresh_state`)."""
        self._opt = self.model.opt
        """The model's options, held once (`model.opt` builds a new accessor per read)."""

    # ---- time ------------------------------------------------------------------------------

    @property
    def rng(self) -> np.random.Generator:
        """The scene's random generator, seeded from `physics.seed` at every reset."""
        if self._rng is None:
            self._rng = np.random.default_rng(self.scene.physics.seed)
        return self._rng

    @property
    def time(self) -> float:
        """Simulated time in seconds since the last reset."""
        return float(self.data.time)

    @property
    def timestep(self) -> float:
        """Seconds of sim time per step."""
        return float(self._opt.timestep)

    @property
    def step_count(self) -> int:
        """Physics steps since the last reset (`time` is exactly this times `timestep`)."""
        return self._steps

    def physics_step(self) -> tuple[int, float]:
        """One MuJoCo step; returns (steps since reset, the timestep it took).

        The clock is the step count times the timestep (not a running sum, which drifts);
        derived quantities now lag the state until something reads them (`refresh`)."""
        data = self.data
        mujoco.mj_step(self.model, data)
        self._steps = step = self._steps + 1
        timestep = self._opt.timestep
        data.time = step * timestep
        self._derived_stale = self._state_stale = True
        return step, timestep

    def restore_initial(self) -> None:
        """Back to time 0: initial joint positions, drives holding them, RNG reseeded."""
        mujoco.mj_resetData(self.model, self.data)
        self._steps = 0
        for robot in self.robots.values():
            for name, value in robot.built.spec.initial_positions.items():
                self.data.qpos[robot.joints[robot.prefix + name].qpos] = value
        self._sync_mimics()
        mujoco.mj_forward(self.model, self.data)
        self._derived_stale = self._state_stale = False
        self.drives.hold_current()
        self._rng = None  # reseeded when next used: a Generator costs tens of microseconds

    # ---- derived quantities ----------------------------------------------------------------

    def refresh(self) -> None:
        """Bring MuJoCo's derived quantities (body poses, velocities, accelerations,
        actuator forces) up to the current state.

        `mj_step` integrates positions and velocities to the new time but leaves what it
        derived from them describing the state one step earlier. Reading poses after a
        step without this would pair the new stamp with the old pose. Runs `mj_forward`
        at most once per step, and only when something reads derived state; it changes
        no state, so the trajectory is the same with or without it.
        """
        if self._derived_stale:
            mujoco.mj_forward(self.model, self.data)
            self._derived_stale = self._state_stale = False

    def refresh_state(self) -> None:
        """Like `refresh`, but only what joint states and TF read: body poses, velocity
        terms and actuator forces, the same numbers `mj_forward` gives, at well under
        half its cost (no collision detection, constraint forces, accelerations or sensor
        values, which `refresh` still brings up to date when something reads them)."""
        if self._state_stale and self._derived_stale:
            model, data = self.model, self.data
            if model.nflex:  # flexes need mj_fwdPosition's mj_flex: the whole forward
                mujoco.mj_forward(model, data)
                self._derived_stale = False
            else:
                mujoco.mj_kinematics(model, data)
                mujoco.mj_comPos(model, data)
                mujoco.mj_tendon(model, data)
                mujoco.mj_transmission(model, data)
                mujoco.mj_fwdVelocity(model, data)
                mujoco.mj_fwdActuation(model, data)
        self._state_stale = False

    # ---- queries ---------------------------------------------------------------------------

    def robot(self, name: str | None = None) -> RobotHandle:
        """The robot called `name` (or the only one)."""
        if name is None and len(self.robots) == 1:
            return next(iter(self.robots.values()))
        if name not in self.robots:
            raise SimError(f"unknown robot '{name}' (robots: {', '.join(self.robots) or 'none'})")
        return self.robots[name]

    def _slots(self, names: Sequence[str] | None) -> list[tuple[str, int, int]]:
        if names is None:
            return self._all_slots
        table = self._slot_table
        out = []
        for name in names:
            if name not in table:
                raise SimError(f"unknown joint '{name}' (joints: {', '.join(table) or 'none'})")
            out.append(table[name])
        return out

    def joint_names(self) -> list[str]:
        """Every robot's 1-DoF joint names (the /joint_states set)."""
        return [n for r in self.robots.values() for n in r.joint_names]

    def joint_indices(
        self, names: Sequence[str] | None = None
    ) -> tuple[list[str], NDArray[np.intp], NDArray[np.intp]]:
        """(names, their qpos indices, their dof indices) of `names` (every 1-DoF joint if
        None), to read many joints from `data.qpos`/`qvel`/`qfrc_actuator` at once."""
        slots = self._slots(names)
        return (
            [n for n, _, _ in slots],
            np.array([q for _, q, _ in slots], dtype=np.intp),
            np.array([d for _, _, d in slots], dtype=np.intp),
        )

    def joint_positions(self, names: Sequence[str] | None = None) -> dict[str, float]:
        """Joint positions (rad or m)."""
        return {n: float(self.data.qpos[q]) for n, q, _ in self._slots(names)}

    def joint_velocities(self, names: Sequence[str] | None = None) -> dict[str, float]:
        """Joint velocities (rad/s or m/s)."""
        return {n: float(self.data.qvel[d]) for n, _, d in self._slots(names)}

    def joint_efforts(self, names: Sequence[str] | None = None) -> dict[str, float]:
        """Force or torque the drives apply to each joint (N or N m)."""
        self.refresh()
        return {n: float(self.data.qfrc_actuator[d]) for n, _, d in self._slots(names)}

    def link_pose(self, name: str) -> Transform:
        """World pose of body `name` (a URDF link name with its robot's prefix, or an object)."""
        self.refresh()
        body = self._body_ids.get(name)
        if body is None:
            try:
                body = self._body_ids[name] = self.model.body(name).id
            except KeyError:
                raise SimError(f"unknown link or body '{name}'") from None
        return Transform(self.data.xmat[body].reshape(3, 3).copy(), self.data.xpos[body].copy())

    def link_poses(self, robot: str | None = None) -> dict[str, Transform]:
        """World poses of every link of `robot` (or of the only robot)."""
        return {name: self.link_pose(name) for name in self.robot(robot).bodies}

    # ---- teleporting -----------------------------------------------------------------------

    def set_joint_positions(self, values: Mapping[str, float]) -> None:
        """Teleport joints (kinematic follower): set positions, zero velocities, move drive
        targets there and update mimic joints, then recompute poses."""
        for name, qpos, dof in self._slots(list(values)):
            self.data.qpos[qpos] = values[name]
            self.data.qvel[dof] = 0.0
            if name in self.drives.joints:
                self.drives.set_position(name, values[name])
        self._sync_mimics()
        mujoco.mj_forward(self.model, self.data)
        self._derived_stale = self._state_stale = False

    def _sync_mimics(self) -> None:
        for robot in self.robots.values():
            for name, slot in robot.joints.items():
                mimic = robot.mimic_of(name)
                if mimic is not None:
                    leader, multiplier, offset = mimic
                    lead = robot.joints[leader]
                    self.data.qpos[slot.qpos] = multiplier * self.data.qpos[lead.qpos] + offset
                    self.data.qvel[slot.dof] = multiplier * self.data.qvel[lead.dof]
