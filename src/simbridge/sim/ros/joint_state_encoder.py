"""sensor_msgs/JointState payloads read straight from MuJoCo's arrays.

The joint list is fixed when the encoder is made, so the message is laid out once
(`simbridge.messages.fastwire.JointStateWriter`) and each publish only gathers the
positions, velocities and efforts with three `ndarray.take` calls into the payload
buffer and stamps it: no per-joint dictionaries, message objects or generic encoding.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from simbridge.messages import WireFormat
from simbridge.messages.fastwire import JointStateWriter
from simbridge.sim.world.world import World

__all__ = ["JointStateEncoder", "stamp_parts"]


def stamp_parts(seconds: float) -> tuple[int, int]:
    """(sec, nanosec) of `seconds`, rounded to the nanosecond as `StampMaker.time` does."""
    return divmod(round(seconds * 1e9), 10**9)


class JointStateEncoder:
    """The joint states of `joints` (every 1-DoF joint if None) as payload bytes.

    `rename` maps a world joint name to the name published (e.g. without a robot's
    prefix); the payload follows the wire `(format, header has seq)` asked for.
    """

    def __init__(
        self,
        world: World,
        joints: Sequence[str] | None = None,
        rename: Callable[[str], str] | None = None,
    ) -> None:
        self.world = world
        names, self._qpos, self._dof = world.joint_indices(joints)
        self.names = [rename(n) for n in names] if rename is not None else names
        """The published joint names, in message order."""
        self._writer: JointStateWriter | None = None

    def encode(self, wire: tuple[WireFormat, bool]) -> bytes:
        """The current joint states, stamped with the sim time (derived quantities such
        as efforts are brought up to date first)."""
        writer = self._writer
        if writer is None or writer.wire != wire:
            writer = self._writer = JointStateWriter(wire[0], self.names, seq=wire[1])
        world = self.world
        world.refresh_state()
        data = world.data
        data.qpos.take(self._qpos, out=writer.position)
        data.qvel.take(self._dof, out=writer.velocity)
        data.qfrc_actuator.take(self._dof, out=writer.effort)
        return writer.finish(*stamp_parts(world.time))
