"""Move a free object with the mouse: a transform gizmo whose drags set the body's pose in
the physics (its free joint), as dragging an object in an editor would."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from simbridge.errors import SimError
from simbridge.sim.world.world import World

if TYPE_CHECKING:
    import viser

__all__ = ["NONE", "ObjectMover", "free_bodies", "place_body"]

NONE = "(none)"
"""The dropdown entry that hides the gizmo."""


def free_bodies(model: mujoco.MjModel) -> dict[str, int]:
    """Bodies that hang on a free joint (movable objects), by name -> body id."""
    found: dict[str, int] = {}
    for joint in range(model.njnt):
        if int(model.jnt_type[joint]) == mujoco.mjtJoint.mjJNT_FREE:
            body = int(model.jnt_bodyid[joint])
            found[model.body(body).name or f"body{body}"] = body
    return found


def place_body(world: World, body: int, position: np.ndarray, wxyz: np.ndarray) -> None:
    """Put free `body` at `position` with orientation `wxyz` (world frame), at rest.

    Call on the simulation thread (`World.post`)."""
    model, data = world.model, world.data
    joint = int(model.body_jntadr[body])
    if joint < 0 or int(model.jnt_type[joint]) != mujoco.mjtJoint.mjJNT_FREE:
        raise SimError(f"body {model.body(body).name!r} has no free joint: it cannot be moved")
    adr, dof = int(model.jnt_qposadr[joint]), int(model.jnt_dofadr[joint])
    quat = np.asarray(wxyz, dtype=np.float64)
    data.qpos[adr : adr + 3] = position
    data.qpos[adr + 3 : adr + 7] = quat / np.linalg.norm(quat)
    data.qvel[dof : dof + 6] = 0.0
    mujoco.mj_forward(model, data)


class ObjectMover:
    """A dropdown of the free objects; the chosen one gets a drag gizmo."""

    def __init__(self, server: viser.ViserServer, world: Callable[[], World]) -> None:
        self.server = server
        self._world = world
        self.bodies: dict[str, int] = {}
        self.gizmo: Any = None
        self.dropdown = server.gui.add_dropdown("Move object", options=(NONE,), initial_value=NONE)
        self.dropdown.on_update(lambda _event: self.select(str(self.dropdown.value)))

    def reset(self, model: mujoco.MjModel) -> None:
        """Offer the free objects of a new world (the scene was cleared)."""
        self.gizmo = None
        self.bodies = free_bodies(model)
        self.dropdown.options = (NONE, *sorted(self.bodies))
        self.dropdown.value = NONE  # type: ignore[misc]

    def select(self, name: str) -> None:
        """Show the gizmo on object `name` (NONE hides it)."""
        if self.gizmo is not None:
            self.gizmo.remove()
            self.gizmo = None
        body = self.bodies.get(name)
        if body is None:
            return
        data = self._world().data
        gizmo = self.server.scene.add_transform_controls(
            "/move_object",
            scale=0.25,
            position=np.array(data.xpos[body]),
            wxyz=np.array(data.xquat[body]),
            depth_test=False,
        )
        gizmo.on_update(lambda _event: self.drag(body, gizmo.position, gizmo.wxyz))
        self.gizmo = gizmo

    def drag(self, body: int, position: np.ndarray, wxyz: np.ndarray) -> None:
        """What a drag of the gizmo does: the body goes there, in the physics."""
        world = self._world()
        pos, quat = np.array(position, dtype=np.float64), np.array(wxyz, dtype=np.float64)
        world.post(lambda: place_body(world, body, pos, quat))
