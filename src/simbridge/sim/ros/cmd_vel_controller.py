"""Drive a differential-drive base from ROS: geometry_msgs/Twist on /cmd_vel -> wheel drives."""

from __future__ import annotations

import logging
from typing import Any

import mujoco
import numpy as np

from simbridge.connector import Connector
from simbridge.errors import SimError
from simbridge.sim.control.diff_drive import (
    DiffDriveConfig,
    DiffDriveController,
    DiffDriveKinematics,
)
from simbridge.sim.control.drive import DriveMode
from simbridge.sim.urdf.mjcf import COLLISION_GROUP
from simbridge.sim.world.callbacks import CallbackHandle
from simbridge.sim.world.world import World

__all__ = ["CmdVelController", "measure_wheels"]

_log = logging.getLogger("simbridge.sim.ros")
_ROUND = {int(mujoco.mjtGeom.mjGEOM_CYLINDER), int(mujoco.mjtGeom.mjGEOM_SPHERE)}


def _wheel_radius(model: mujoco.MjModel, joint: str) -> float:
    body = int(model.joint(joint).bodyid[0])
    radii = [
        float(model.geom_size[g][0])
        for g in range(model.ngeom)
        if model.geom_bodyid[g] == body
        and int(model.geom_type[g]) in _ROUND
        and model.geom_group[g] == COLLISION_GROUP
    ]
    if not radii:
        raise SimError(
            f"diff drive: wheel joint {joint!r} moves no collision cylinder or sphere; "
            "set wheel_radius in the scene"
        )
    return max(radii)


def measure_wheels(world: World, left: str, right: str) -> DiffDriveKinematics:
    """Wheel radius (the wheels' collision cylinders, averaged) and separation (distance
    between the two wheel joints) of the model as it stands."""
    model = world.model
    for joint in (left, right):
        try:
            model.joint(joint)
        except KeyError:
            raise SimError(
                f"diff drive: no joint {joint!r} (joints: {', '.join(world.joint_names())})"
            ) from None
    radius = (_wheel_radius(model, left) + _wheel_radius(model, right)) / 2
    anchors = world.data.xanchor
    separation = float(
        np.linalg.norm(anchors[model.joint(left).id] - anchors[model.joint(right).id])
    )
    return DiffDriveKinematics(radius, separation)


class CmdVelController:
    """Subscribes to the Twist topic and sets the wheel velocity targets after every step.

    Commands are applied on the simulation thread and stamped with the sim time, so the
    command timeout runs in simulated seconds. The wheel drives switch to velocity mode.
    """

    def __init__(self, world: World, connector: Connector, config: DiffDriveConfig) -> None:
        self.world, self.connector, self.config = world, connector, config
        for joint in (config.left_joint, config.right_joint):
            world.drives.spec(joint)  # SimError for a joint without a drive
        radius, separation = config.wheel_radius, config.wheel_separation
        if radius is None or separation is None:
            measured = measure_wheels(world, config.left_joint, config.right_joint)
            radius = radius or measured.wheel_radius
            separation = separation or measured.wheel_separation
        self.kinematics = DiffDriveKinematics(radius, separation)
        self.controller = DiffDriveController(self.kinematics, config.limits, config.cmd_timeout)
        self.errors: list[str] = []
        """Commands rejected so far (also logged), newest last."""
        self._callbacks: list[CallbackHandle] = []

    def start(self) -> None:
        """Switch the wheels to velocity drives, subscribe, and update after every step."""
        drives = self.world.drives
        for joint in (self.config.left_joint, self.config.right_joint):
            drives.set_spec(joint, drives.spec(joint).with_changes(mode=DriveMode.VELOCITY))
            drives.set_velocity(joint, 0.0)
        self.connector.subscribe(self.config.topic, "geometry_msgs/Twist", self._receive)
        self._callbacks = [
            self.world.add_step_callback(lambda world: self.update()),
            self.world.add_reset_callback(lambda world: self.controller.reset()),
        ]

    def _receive(self, msg: Any) -> None:
        linear, angular = float(msg.linear.x), float(msg.angular.z)

        def apply() -> None:
            try:
                self.controller.command(linear, angular, self.world.time)
            except SimError as exc:
                self.errors.append(str(exc))
                _log.warning("cmd_vel rejected: %s", exc)

        self.world.post(apply)

    def update(self) -> None:
        """Set the wheel targets for the current sim time."""
        left, right = self.controller.update(self.world.time)
        self.world.drives.set_velocity(self.config.left_joint, left)
        self.world.drives.set_velocity(self.config.right_joint, right)

    def close(self) -> None:
        """Stop updating (after steps and resets), unsubscribe, and aim the wheels at
        standstill."""
        if self._callbacks:
            for callback in self._callbacks:
                callback.remove()
            self._callbacks.clear()
            self.connector.unsubscribe(self.config.topic)
            self.world.post(self._stop_wheels)

    def _stop_wheels(self) -> None:
        self.controller.reset()
        self.update()
