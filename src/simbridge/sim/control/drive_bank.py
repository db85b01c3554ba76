"""Per-joint drives on a compiled MuJoCo model: one affine `general` actuator per driven joint."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import SimError
from simbridge.sim.control.drive import DriveMode, DriveSpec
from simbridge.sim.urdf.document import fmt

__all__ = ["Actuators", "DriveBank", "DriveTarget", "add_drive_actuator"]

Actuators = slice | NDArray[np.intp]
"""Some drives' actuator indices (`DriveBank.actuators`)."""


def add_drive_actuator(actuators: ET.Element, joint: str, force_limit: float | None) -> None:
    """Declare the actuator that drives MuJoCo joint `joint` (gains are set by `DriveBank`).

    Force = ctrl - stiffness * q - damping * qdot, with ctrl = stiffness * target +
    damping * target_velocity, which is the ArticulationDrive law with both targets.
    """
    attrs = {
        "name": joint,
        "joint": joint,
        "gainprm": "1",
        "biastype": "affine",
        "biasprm": "0 0 0",
        "ctrllimited": "false",
    }
    if force_limit is not None and math.isfinite(force_limit):
        attrs.update(forcelimited="true", forcerange=fmt((-force_limit, force_limit)))
    ET.SubElement(actuators, "general", attrs)


@dataclass(frozen=True)
class DriveTarget:
    """The current goal of one drive."""

    position: float = 0.0
    velocity: float = 0.0
    effort: float = 0.0


class DriveBank:
    """Targets and gains of every driven joint; writes `data.ctrl` whenever a target changes.

    Targets live in arrays indexed by actuator, so a learning env can aim many joints with
    one `set_positions` call (a few NumPy operations) instead of one call per joint.
    """

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, specs: Mapping[str, DriveSpec]
    ) -> None:
        self.model, self.data = model, data
        self._specs: dict[str, DriveSpec] = {}
        self._ctrl = data.ctrl  # a view on data's memory: no pybind property per write
        self._actuator: dict[str, int] = {}
        self._qpos: dict[str, int] = {}
        size = model.nu
        self._position, self._velocity, self._effort = (np.zeros(size) for _ in range(3))
        self._low, self._high = np.full(size, -np.inf), np.full(size, np.inf)
        # ctrl = effort where _is_effort, else _kp * position + _kd * velocity (0, 0: NONE)
        self._kp, self._kd = np.zeros(size), np.zeros(size)
        self._is_effort = np.zeros(size, np.bool_)
        self._any_effort = False
        for name, spec in specs.items():
            try:
                act = model.actuator(name).id
                jnt = model.joint(name)
            except KeyError:
                raise SimError(f"joint '{name}' has no drive actuator in the model") from None
            self._actuator[name] = act
            self._qpos[name] = int(jnt.qposadr[0])
            if model.jnt_limited[jnt.id]:
                self._low[act], self._high[act] = (float(v) for v in jnt.range)
            self.set_spec(name, spec)

    @property
    def joints(self) -> list[str]:
        """Names of the driven joints."""
        return list(self._specs)

    def _check(self, joint: str) -> int:
        if joint not in self._actuator:
            raise SimError(
                f"joint '{joint}' has no drive (driven joints: {', '.join(self._specs) or 'none'})"
            )
        return self._actuator[joint]

    def actuators(self, joints: Sequence[str]) -> Actuators:
        """The actuators of `joints`, for `positions` and `set_positions`: a slice when they
        are consecutive (NumPy reads and writes views then, no index arrays)."""
        ids = [self._check(joint) for joint in joints]
        if ids and ids == list(range(ids[0], ids[0] + len(ids))):
            return slice(ids[0], ids[0] + len(ids))
        return np.array(ids, np.intp)

    def spec(self, joint: str) -> DriveSpec:
        """The drive settings of `joint`."""
        self._check(joint)
        return self._specs[joint]

    def target(self, joint: str) -> DriveTarget:
        """The current target of `joint`."""
        act = self._check(joint)
        return DriveTarget(
            float(self._position[act]), float(self._velocity[act]), float(self._effort[act])
        )

    def set_spec(self, joint: str, spec: DriveSpec) -> None:
        """Change mode and gains of `joint` (the force limit keeps what the model declared
        unless `spec.force_limit` is set)."""
        act = self._check(joint)
        kp, kd = spec.gains()
        self.model.actuator_biasprm[act, :3] = (0.0, -kp, -kd)
        if spec.force_limit is not None:  # inf: unlimited
            limited = math.isfinite(spec.force_limit)
            self.model.actuator_forcelimited[act] = int(limited)
            if limited:
                self.model.actuator_forcerange[act] = (-spec.force_limit, spec.force_limit)
        self._specs[joint] = spec
        self._kp[act], self._kd[act] = kp, kd  # (0, 0) in EFFORT and NONE modes
        self._is_effort[act] = spec.mode is DriveMode.EFFORT
        self._any_effort = bool(self._is_effort.any())
        self._write(act)

    def _write(self, act: int) -> None:
        if self._is_effort[act]:
            self._ctrl[act] = self._effort[act]
        else:
            position, velocity = self._position[act], self._velocity[act]
            self._ctrl[act] = self._kp[act] * position + self._kd[act] * velocity

    def set_position(self, joint: str, position: float, velocity: float = 0.0) -> None:
        """Aim `joint` at `position` (clamped to its limits) moving at `velocity`."""
        act = self._check(joint)
        self._position[act] = min(max(position, self._low[act]), self._high[act])
        self._velocity[act] = velocity
        self._write(act)

    def positions(self, actuators: Actuators) -> NDArray[np.float64]:
        """The position targets of `actuators` (from `actuators(joints)`), a new array."""
        return self._position[actuators].copy()

    def set_positions(self, actuators: Actuators, positions: NDArray[np.float64]) -> None:
        """`set_position` (target velocity 0) of many joints at once: `actuators` from
        `actuators(joints)`, `positions` in the same order."""
        clamped, ctrl = self.position_controls(actuators, positions)
        self._position[actuators] = clamped
        self._velocity[actuators] = 0.0
        self._ctrl[actuators] = ctrl

    def position_controls(
        self, actuators: Actuators, positions: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The clamped targets and the `ctrl` that `set_positions(actuators, positions)`
        writes, changing nothing. `positions` may have leading axes: a learning env's many
        worlds on this model (same gains and limits; this bank's effort targets) at once."""
        clamped = np.maximum(positions, self._low[actuators])
        np.minimum(clamped, self._high[actuators], out=clamped)
        ctrl = self._kp[actuators] * clamped
        if self._any_effort:  # EFFORT drives take their effort whatever the position
            ctrl = np.where(self._is_effort[actuators], self._effort[actuators], ctrl)
        return clamped, ctrl

    def position_controls_into(
        self,
        actuators: Actuators,
        positions: NDArray[np.float64],
        clamped: NDArray[np.float64],
        ctrl: NDArray[np.float64],
    ) -> None:
        """`position_controls`, its bits written into `clamped` and `ctrl` (views of the
        caller's arrays, of the shape of `positions`) instead of new arrays."""
        np.maximum(positions, self._low[actuators], out=clamped)
        np.minimum(clamped, self._high[actuators], out=clamped)
        np.multiply(self._kp[actuators], clamped, out=ctrl)
        if self._any_effort:
            np.copyto(ctrl, self._effort[actuators], where=self._is_effort[actuators])

    def set_targets(
        self, actuators: Actuators, positions: NDArray[np.float64], velocities: NDArray[np.float64]
    ) -> None:
        """`set_position` of many joints at once, with target velocities (a trajectory
        follower's step): `actuators` from `actuators(joints)`, arrays in the same order."""
        clamped = np.maximum(positions, self._low[actuators])
        np.minimum(clamped, self._high[actuators], out=clamped)
        self._position[actuators] = clamped
        self._velocity[actuators] = velocities
        ctrl = self._kp[actuators] * clamped + self._kd[actuators] * velocities
        if self._any_effort:
            ctrl = np.where(self._is_effort[actuators], self._effort[actuators], ctrl)
        self._ctrl[actuators] = ctrl

    def set_velocity(self, joint: str, velocity: float) -> None:
        """Set the target velocity (VELOCITY mode, or the feed-forward of POSITION mode)."""
        act = self._check(joint)
        self._velocity[act] = velocity
        self._write(act)

    def set_effort(self, joint: str, effort: float) -> None:
        """Set the commanded force or torque (EFFORT mode)."""
        act = self._check(joint)
        self._effort[act] = effort
        self._write(act)

    def hold_current(self) -> None:
        """Make every position target the joint's current position, velocity targets zero."""
        for joint, adr in self._qpos.items():
            act = self._actuator[joint]
            self._position[act] = self.data.qpos[adr]
            self._velocity[act] = self._effort[act] = 0.0
            self._write(act)
