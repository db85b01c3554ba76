"""ros_control's forward command controllers for one robot:
joint_group_{position,velocity,effort}_controller, one std_msgs/Float64MultiArray value per
joint on `<ns>/<name>/command`, applied on the simulation thread."""

from __future__ import annotations

import logging
from typing import Any

from simbridge.connector import Connector
from simbridge.errors import SimError
from simbridge.sim.control.drive import DriveMode
from simbridge.sim.ros.names import RobotNames, resolve_name
from simbridge.sim.scene.spec import GroupControllerSpec
from simbridge.sim.world.world import World

__all__ = ["GroupCommandController"]

_log = logging.getLogger("simbridge.sim.ros")


class GroupCommandController:
    """Sets position, velocity or effort targets of its joints from each command."""

    def __init__(
        self,
        world: World,
        connector: Connector,
        names: RobotNames,
        namespace: str,
        spec: GroupControllerSpec,
    ) -> None:
        self.world, self.connector, self.spec = world, connector, spec
        self.joints = [names.world_joint(j) for j in spec.joints]
        self.mode = DriveMode.parse(spec.mode)
        self._configured = {j: world.drives.spec(j) for j in self.joints}  # SimError: undriven
        self.topic = f"{resolve_name(namespace, spec.name)}/command"
        self.errors: list[str] = []
        """Commands rejected so far (also logged), newest last."""
        self._subscribed = False

    def start(self) -> GroupCommandController:
        """Subscribe to the command topic."""
        world = self.world
        self.connector.subscribe(
            self.topic,
            "std_msgs/Float64MultiArray",
            lambda msg: world.post(lambda: self._on_command(msg)),
        )
        self._subscribed = True
        return self

    def close(self) -> None:
        """Unsubscribe."""
        if self._subscribed:
            self.connector.unsubscribe(self.topic)
            self._subscribed = False

    def _on_command(self, msg: Any) -> None:
        values = [float(v) for v in msg.data]
        if len(values) != len(self.joints):
            error = SimError(
                f"{self.topic}: {len(values)} values for {len(self.joints)} joints "
                f"({', '.join(self.spec.joints)})"
            )
            self.errors.append(str(error))
            _log.warning("command rejected: %s", error)
            return
        drives = self.world.drives
        for joint, value in zip(self.joints, values, strict=True):
            if drives.spec(joint).mode is not self.mode:
                drives.set_spec(joint, self._configured[joint].with_changes(mode=self.mode))
            if self.mode is DriveMode.POSITION:
                drives.set_position(joint, value)
            elif self.mode is DriveMode.VELOCITY:
                drives.set_velocity(joint, value)
            else:
                drives.set_effort(joint, value)
