"""Per-joint drives on a compiled MuJoCo model: one affine `general` actuator per driven joint."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass

import mujoco

from simbridge.errors import SimError
from simbridge.sim.control.drive import DriveMode, DriveSpec
from simbridge.sim.urdf.document import fmt

__all__ = ["DriveBank", "DriveTarget", "add_drive_actuator"]


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
    """Targets and gains of every driven joint; writes `data.ctrl` whenever a target changes."""

    def __init__(
        self, model: mujoco.MjModel, data: mujoco.MjData, specs: Mapping[str, DriveSpec]
    ) -> None:
        self.model, self.data = model, data
        self._specs: dict[str, DriveSpec] = {}
        self._targets: dict[str, DriveTarget] = {}
        self._gains: dict[str, tuple[float, float]] = {}
        self._ctrl = data.ctrl  # a view on data's memory: no pybind property per write
        self._actuator: dict[str, int] = {}
        self._qpos: dict[str, int] = {}
        self._range: dict[str, tuple[float, float] | None] = {}
        for name, spec in specs.items():
            try:
                act = model.actuator(name).id
                jnt = model.joint(name)
            except KeyError:
                raise SimError(f"joint '{name}' has no drive actuator in the model") from None
            self._actuator[name] = act
            self._qpos[name] = int(jnt.qposadr[0])
            low, high = (float(v) for v in jnt.range)
            self._range[name] = (low, high) if model.jnt_limited[jnt.id] else None
            self.set_spec(name, spec)
            self._targets[name] = DriveTarget()

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

    def spec(self, joint: str) -> DriveSpec:
        """The drive settings of `joint`."""
        self._check(joint)
        return self._specs[joint]

    def target(self, joint: str) -> DriveTarget:
        """The current target of `joint`."""
        self._check(joint)
        return self._targets[joint]

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
        self._gains[joint] = (kp, kd)
        if joint in self._targets:
            self._write(joint)

    def _write(self, joint: str) -> None:
        spec, target = self._specs[joint], self._targets[joint]
        if spec.mode is DriveMode.EFFORT:
            ctrl = target.effort
        elif spec.mode is DriveMode.NONE:
            ctrl = 0.0
        else:
            kp, kd = self._gains[joint]
            ctrl = kp * target.position + kd * target.velocity
        self._ctrl[self._actuator[joint]] = ctrl

    def set_position(self, joint: str, position: float, velocity: float = 0.0) -> None:
        """Aim `joint` at `position` (clamped to its limits) moving at `velocity`."""
        self._check(joint)
        limits = self._range[joint]
        if limits is not None:
            position = min(max(position, limits[0]), limits[1])
        self._targets[joint] = DriveTarget(position, velocity, self._targets[joint].effort)
        self._write(joint)

    def set_velocity(self, joint: str, velocity: float) -> None:
        """Set the target velocity (VELOCITY mode, or the feed-forward of POSITION mode)."""
        self._check(joint)
        old = self._targets[joint]
        self._targets[joint] = DriveTarget(old.position, velocity, old.effort)
        self._write(joint)

    def set_effort(self, joint: str, effort: float) -> None:
        """Set the commanded force or torque (EFFORT mode)."""
        self._check(joint)
        old = self._targets[joint]
        self._targets[joint] = DriveTarget(old.position, old.velocity, effort)
        self._write(joint)

    def hold_current(self) -> None:
        """Make every position target the joint's current position, velocity targets zero."""
        for joint, adr in self._qpos.items():
            self._targets[joint] = DriveTarget(float(self.data.qpos[adr]), 0.0, 0.0)
            self._write(joint)
