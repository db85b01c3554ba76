"""Where the live view's camera starts: looking at the scene's robots (and its free objects)
from a diagonal, near enough that they fill the view.

Floors, walls and tables are left out of the framing: a 20 m floor would put the robot in
the distance. Each chosen body's visual shapes are bounded by spheres in the world frame;
the camera looks at the centre of their bounding box from a distance at which the box's
enclosing sphere fits the vertical field of view, and never nearer than `MIN_DISTANCE`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import mujoco
import numpy as np

from simbridge.sim.view.mover import free_bodies
from simbridge.sim.view.shapes import Shape
from simbridge.sim.world.world import World

__all__ = ["DIRECTION", "MIN_DISTANCE", "Framing", "frame_bodies", "framed_bodies", "framing"]

MIN_DISTANCE = 0.75
"""Metres: the camera stays this far from the target, however small the robot."""
DIRECTION = np.array([1.2, 1.0, 0.8]) / np.linalg.norm([1.2, 1.0, 0.8])
"""From the target towards the camera: front right, above."""


@dataclass(frozen=True)
class Framing:
    """The initial camera: where it looks, from where, and what it bounds."""

    target: np.ndarray
    position: np.ndarray
    radius: float
    """Of the sphere around the framed bodies' shapes (m)."""

    @property
    def distance(self) -> float:
        """From the camera to the target (m)."""
        return float(np.linalg.norm(self.position - self.target))


def framed_bodies(world: World) -> set[int]:
    """The robots' bodies and the free objects (bodies on a free joint); every body but the
    world's when the scene has neither."""
    chosen = {body for robot in world.robots.values() for body in robot.bodies.values()}
    chosen |= set(free_bodies(world.model).values())
    return chosen or set(range(1, world.model.nbody))


def _bound(shape: Shape) -> float:
    """Radius of a sphere around `shape`, centred on its origin."""
    if shape.kind == "box":
        return 0.5 * math.hypot(*shape.size)
    if shape.kind == "sphere":
        return shape.size[0]
    if shape.kind == "cylinder":
        return math.hypot(shape.size[0], 0.5 * shape.size[1])
    assert shape.vertices is not None
    return float(np.linalg.norm(shape.vertices, axis=1).max()) if len(shape.vertices) else 0.0


def frame_bodies(
    data: mujoco.MjData,
    shapes: Iterable[Shape],
    bodies: set[int],
    fov: float,
) -> Framing | None:
    """Frame the shapes of `bodies` (posed as in `data`) for a camera with vertical field
    of view `fov` (radians); None when none of them has a shape."""
    lows, highs = [], []
    for shape in shapes:
        if shape.body not in bodies:
            continue
        rotation = np.asarray(data.xmat[shape.body]).reshape(3, 3)
        centre = np.asarray(data.xpos[shape.body]) + rotation @ np.asarray(shape.position)
        radius = _bound(shape)
        lows.append(centre - radius)
        highs.append(centre + radius)
    if not lows:
        return None
    low, high = np.min(lows, axis=0), np.max(highs, axis=0)
    target = 0.5 * (low + high)
    radius = 0.5 * float(np.linalg.norm(high - low))
    distance = max(MIN_DISTANCE, radius / math.sin(0.5 * fov))
    return Framing(target, target + DIRECTION * distance, radius)


def framing(world: World, shapes: Iterable[Shape], fov: float) -> Framing | None:
    """The initial camera for `world`: its robots and free objects framed."""
    return frame_bodies(world.data, shapes, framed_bodies(world), fov)
