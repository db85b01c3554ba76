"""`type: placement`: objects stood on a surface at random spots and headings, no two
overlapping.

    - type: placement
      objects: [cube*]           # bodies (scene objects) to place; names or glob patterns
      surface: table             # a body with a box geom: they stand on its top face
      area: [0.5, 0.7]           # size (m) of the region used, centred on the face
                                 # (default: the whole face)
      margin: 0.01               # gap (m) kept between footprints and to the region's edge
      yaw: [-180, 180]           # heading about the surface normal (degrees)
      tilt: [0, 0]               # roll and pitch (degrees): lying objects rest on their
                                 # lowest bounding-box corner

Footprints are the circles around each object's rotated bounding box; an object that finds
no free spot in 100 draws is left out of the frame (hidden).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import PerceptionError
from simbridge.perception.randomizers.base import FrameState, Randomizer
from simbridge.perception.randomizers.materials import matching_bodies
from simbridge.perception.section import Range, Section
from simbridge.perception.shapes import ShapeCache, geom_extent
from simbridge.sim import World

__all__ = ["HIDDEN_GROUP", "PlacementRandomizer", "Surface", "set_body_pose"]

FloatArray = NDArray[np.float64]
HIDDEN_GROUP = 5
"""A geom group the renderer does not draw: where left-out geoms go for a frame."""
TRIES = 100
_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)
_FREE = int(mujoco.mjtJoint.mjJNT_FREE)


def rotation_rpy(roll: float, pitch: float, yaw: float) -> FloatArray:
    """Fixed-axis roll, pitch, yaw (URDF order) as a matrix."""
    cr, sr, cp, sp, cy, sy = (f(a) for a in (roll, pitch, yaw) for f in (math.cos, math.sin))
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return np.asarray(rz @ ry @ rx, dtype=np.float64)


def set_body_pose(model: mujoco.MjModel, data: mujoco.MjData, body: int, position: FloatArray,
                  rotation: FloatArray) -> None:  # fmt: skip
    """Move a body: a free joint's position, a mocap body's target or a static body's
    placement (static bodies are children of the world)."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, rotation.reshape(-1))
    joint = int(model.body_jntadr[body])
    if joint >= 0 and int(model.jnt_type[joint]) == _FREE:
        address = int(model.jnt_qposadr[joint])
        data.qpos[address : address + 3] = position
        data.qpos[address + 3 : address + 7] = quat
    elif int(model.body_mocapid[body]) >= 0:
        data.mocap_pos[model.body_mocapid[body]] = position
        data.mocap_quat[model.body_mocapid[body]] = quat
    else:
        model.body_pos[body] = position
        model.body_quat[body] = quat


def body_corners(model: mujoco.MjModel, shapes: ShapeCache, body: int) -> FloatArray | None:
    """Bounding-box corners of a body's drawn geoms, in the body frame."""
    corners = []
    for geom in range(model.ngeom):
        if int(model.geom_bodyid[geom]) != body or model.geom_group[geom] >= 3:
            continue
        extent = geom_extent(shapes, geom)
        if extent is None:
            continue
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, model.geom_quat[geom])
        corners.append(model.geom_pos[geom] + extent @ rotation.reshape(3, 3).T)
    return np.vstack(corners) if corners else None


@dataclass
class Surface:
    """The top face of a box geom: its centre, axes (z up out of the face), half sizes."""

    name: str
    center: FloatArray
    axes: FloatArray
    half: FloatArray

    @classmethod
    def of_body(cls, world: World, name: str, area: tuple[float, ...] | None) -> Surface:
        model, data = world.model, world.data
        try:
            body = model.body(name).id
        except KeyError:
            raise PerceptionError(f"surface: no body '{name}'") from None
        boxes = [
            g
            for g in range(model.ngeom)
            if model.geom_bodyid[g] == body and model.geom_type[g] == _BOX
        ]
        if not boxes:
            raise PerceptionError(f"surface: body '{name}' has no box geom")
        geom = boxes[0]
        axes = data.geom_xmat[geom].reshape(3, 3).copy()
        size = np.asarray(model.geom_size[geom], dtype=float)
        center = data.geom_xpos[geom] + axes[:, 2] * size[2]
        half = size[:2].copy() if area is None else np.minimum(np.array(area) / 2, size[:2])
        return cls(name, center, axes, half)

    def place(
        self,
        corners: FloatArray,
        rotation: FloatArray,
        margin: float,
        taken: list[tuple[float, float, float]],
        rng: np.random.Generator,
    ) -> FloatArray | None:
        """A world position for an object whose body-frame box `corners` are turned by
        `rotation` (surface frame) so it stands on the face clear of `taken` footprints
        (then added to them); None when no spot is free."""
        turned = corners @ rotation.T
        radius = float(np.max(np.hypot(turned[:, 0], turned[:, 1])))
        room = self.half - radius - margin
        if (room < 0).any():
            return None
        for _ in range(TRIES):
            x, y = rng.uniform(-room[0], room[0]), rng.uniform(-room[1], room[1])
            if all(math.hypot(x - a, y - b) >= radius + r + margin for a, b, r in taken):
                taken.append((x, y, radius))
                local = np.array([x, y, -float(turned[:, 2].min())])
                return np.asarray(self.center + self.axes @ local, dtype=np.float64)
        return None


class PlacementRandomizer(Randomizer):
    kind = "placement"
    KEYS = ("type", "objects", "surface", "area", "margin", "yaw", "tilt")

    def __init__(self, section: Section) -> None:
        self.name = "objects"
        self.patterns = section.strings("objects")
        if not self.patterns:
            raise section.error("missing key 'objects' (body names or glob patterns)")
        self.surface_name = section.string("surface", "")
        if not self.surface_name:
            raise section.error("missing key 'surface' (a body with a box geom)")
        self.area = section.vector("area", 2, ()) if section.has("area") else None
        self.margin = section.number("margin", 0.01, 0.0)
        self.yaw: Range = section.range("yaw", (-180.0, 180.0))
        self.tilt: Range = section.range("tilt", (0.0, 0.0), -180.0, 180.0)
        section.done(self.KEYS)
        self.bodies: list[tuple[int, FloatArray, list[int]]] = []
        self.surface: Surface | None = None

    def bind(self, world: World) -> None:
        model = world.model
        shapes = ShapeCache(model)
        self.surface = Surface.of_body(world, self.surface_name, self.area)
        self.bodies = []
        for body in matching_bodies(model, self.patterns, self.name):
            corners = body_corners(model, shapes, body)
            if corners is None:
                continue
            geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body]
            self.bodies.append((body, corners, geoms))

    def apply(self, state: FrameState, rng: np.random.Generator) -> None:
        assert self.surface is not None
        taken = state.occupied.setdefault(self.surface.name, [])
        for body, corners, geoms in self.bodies:
            roll, pitch = (math.radians(rng.uniform(*self.tilt)) for _ in range(2))
            yaw = math.radians(rng.uniform(*self.yaw))
            turn = rotation_rpy(roll, pitch, yaw)
            spot = self.surface.place(corners, turn, self.margin, taken, rng)
            if spot is None:
                state.model.geom_group[geoms] = HIDDEN_GROUP
                continue
            set_body_pose(state.model, state.data, body, spot, self.surface.axes @ turn)
