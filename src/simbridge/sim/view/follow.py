"""The live view's camera follows a moving robot (or a chosen body): when the body moves,
every browser's camera and its target move by as much, so the angle and distance the user
chose stay and a mobile robot never drives out of the picture.

The page's "Follow" dropdown picks what to follow: a robot (its root body), a free
object, or nothing. `ViewOptions.follow` sets the start: None follows the first robot.
"""

from __future__ import annotations

from contextlib import suppress
from typing import TYPE_CHECKING

import numpy as np

from simbridge.errors import SimError, did_you_mean
from simbridge.sim.view.mover import free_bodies
from simbridge.sim.world.world import World

if TYPE_CHECKING:
    import viser

__all__ = ["NOTHING", "CameraFollow", "follow_targets"]

NOTHING = "nothing"
"""The dropdown entry (and `ViewOptions.follow` value) that keeps the camera still."""
MIN_SHIFT = 1e-3
"""Metres the body must move before the cameras are moved (and messages sent)."""


def follow_targets(world: World) -> dict[str, int]:
    """What the view can follow: each robot by name (its root body), then each free
    object by name (its body)."""
    targets = {
        name: robot.bodies[robot.built.mjcf.body_name(robot.robot.root)]
        for name, robot in world.robots.items()
    }
    for name, body in free_bodies(world.model).items():
        if body not in targets.values():  # a mobile robot's base is a free body too
            targets.setdefault(name, body)
    return targets


class CameraFollow:
    """Moves the browsers' cameras (and the initial camera new browsers get) with one body."""

    def __init__(self, server: viser.ViserServer) -> None:
        """Adds the "Follow" dropdown; `reset` gives it a world's choices."""
        self.server = server
        self.body: int | None = None
        self._targets: dict[str, int] = {}
        self._last: np.ndarray | None = None
        self.dropdown = server.gui.add_dropdown("Follow", options=(NOTHING,), initial_value=NOTHING)
        self.dropdown.on_update(lambda _event: self.select(str(self.dropdown.value)))

    def reset(self, world: World, follow: str | None) -> None:
        """Offer `world`'s robots and free objects; follow `follow` (a robot, an object or
        any body by name; None: the first robot; "nothing": none)."""
        targets = follow_targets(world)
        names = [world.model.body(i).name for i in range(world.model.nbody)]
        if follow is None:
            follow = next(iter(world.robots), NOTHING)
        elif follow != NOTHING and follow not in targets:
            if follow not in names:
                raise SimError(
                    f"the view cannot follow '{follow}': no robot or body of that name"
                    f"{did_you_mean(follow, [*targets, *names])} (robots and free objects: "
                    f"{', '.join(targets) or 'none'}; or any body of the model)"
                )
            targets[follow] = names.index(follow)
        self._targets = targets
        self.dropdown.options = (NOTHING, *targets)
        self.dropdown.value = follow  # type: ignore[misc]
        self.select(follow)

    def select(self, name: str) -> None:
        """Follow `name` from now on (the dropdown calls this)."""
        self.body = self._targets.get(name)
        self._last = None

    def update(self, xpos: np.ndarray) -> None:
        """Move the cameras by how far the followed body moved since the last call (the
        view's streaming thread calls this with every pose snapshot)."""
        if self.body is None:
            return
        now = np.array(xpos[self.body])
        if self._last is None:
            self._last = now
            return
        shift = now - self._last
        if not np.abs(shift).max() > MIN_SHIFT:
            return
        self._last = now
        initial = self.server.initial_camera  # for browsers still to come, and "Reset View"
        look_at = np.asarray(initial.look_at) + shift
        initial.position = np.asarray(initial.position) + shift
        initial.look_at = look_at
        for client in self.server.get_clients().values():
            # a browser that has not reported its camera yet starts from the initial one;
            # its handle's position (which moves the target along) is not readable until then
            with suppress(AssertionError), client.atomic():
                client.camera.position = np.asarray(client.camera.position) + shift
