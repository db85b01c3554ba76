"""`type: distractors`: clutter of random primitives (and meshes from a folder), on a
surface or floating in a region, each with a random colour and maybe a texture.

    - type: distractors
      count: [0, 6]              # how many per frame (slots are made for the most)
      shapes: [box, sphere, cylinder, capsule, ellipsoid]   # and `mesh` with `meshes:`
      size: [0.02, 0.08]         # extent (m) of each axis of a primitive
      meshes: distractor_meshes/ # a folder of mesh files (STL, OBJ, DAE, PLY...)
      mesh_scale: 1.0            # meshes are scaled by this
      surface: table             # stand on this box's top face (as `placement`, sharing its
                                 # footprints), or else float in `region`:
      area: [0.5, 0.7]           # the part of the face used (default: all of it)
      region: {center: [0, 0, 0.5], size: [1, 1, 0.5]}
      yaw: [-180, 180]           # heading on a surface (degrees); in a region any rotation
      label: distractor          # their class (default: not labelled, background clutter)
      hue: [0, 1]                # colours, as for `materials`
      saturation: [0.2, 1]
      value: [0.2, 1]
      texture: 0.5               # probability of a texture from the procedural set
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np

from simbridge.perception.randomizers.appearance import ColourRanges, add_textures, texture_ids
from simbridge.perception.randomizers.base import FrameState, Randomizer
from simbridge.perception.randomizers.placement import (
    HIDDEN_GROUP,
    Surface,
    rotation_rpy,
    set_body_pose,
)
from simbridge.perception.section import Range, Section
from simbridge.perception.shapes import ShapeCache, geom_extent
from simbridge.sim import World
from simbridge.sim.urdf import MeshCache
from simbridge.sim.urdf.document import MjcfDocument, fmt

__all__ = ["DistractorsRandomizer"]

SHAPES = ("box", "sphere", "cylinder", "capsule", "ellipsoid", "mesh")
MESH_SUFFIXES = (".stl", ".obj", ".dae", ".ply", ".glb", ".gltf", ".off")
_TYPES = {name: int(getattr(mujoco.mjtGeom, f"mjGEOM_{name.upper()}")) for name in SHAPES}
_RGB = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
MAX_DISTRACTORS = 64


class DistractorsRandomizer(Randomizer):
    kind = "distractors"
    KEYS = ("type", "count", "shapes", "size", "meshes", "mesh_scale", "surface", "area",
            "region", "yaw", "label", "texture", *ColourRanges.KEYS)  # fmt: skip

    def __init__(self, section: Section, index: int, base_dir: Path) -> None:
        self.index = index
        self.count = section.range("count", (0.0, 6.0), 0.0, MAX_DISTRACTORS)
        if self.count != tuple(round(c) for c in self.count):
            raise section.error(f"count must be whole numbers, got {list(self.count)}", "count")
        self.shapes = section.strings("shapes", SHAPES[:5])
        for shape in self.shapes:
            if shape not in SHAPES:
                raise section.error(
                    f"unknown shape {shape!r} (valid: {', '.join(SHAPES)})", "shapes"
                )
        self.size: Range = section.range("size", (0.02, 0.08), 1e-4)
        self.meshes: list[Path] = []
        if section.has("meshes"):
            folder = Path(section.string("meshes", "")).expanduser()
            folder = folder if folder.is_absolute() else base_dir / folder
            if not folder.is_dir():
                raise section.error(f"'{folder}' is not a folder", "meshes")
            self.meshes = sorted(p for p in folder.iterdir() if p.suffix.lower() in MESH_SUFFIXES)
            if not self.meshes:
                raise section.error(
                    f"no mesh files ({', '.join(MESH_SUFFIXES)}) in '{folder}'", "meshes"
                )
        if "mesh" in self.shapes and not self.meshes:
            raise section.error("shape 'mesh' needs 'meshes' (a folder of mesh files)", "shapes")
        if self.meshes and "mesh" not in self.shapes:
            self.shapes = (*self.shapes, "mesh")
        self.mesh_scale = section.number("mesh_scale", 1.0, 1e-6)
        self.surface_name = section.string("surface", "") or None
        self.area = section.vector("area", 2, ()) if section.has("area") else None
        region = section.sub("region")
        self.center = np.array(region.vector("center", 3, (0.0, 0.0, 0.5)))
        self.extent = np.array(region.vector("size", 3, (1.0, 1.0, 0.5)))
        region.done(("center", "size"))
        self.yaw: Range = section.range("yaw", (-180.0, 180.0))
        self.label = section.string("label", "") or None
        self.colours = ColourRanges.parse(section)
        self.texture = section.number("texture", 0.5, 0.0, 1.0)
        section.done(self.KEYS)
        self.slots: list[tuple[int, int, int]] = []  # body, geom, material
        self.mesh_ids: list[int] = []
        self.textures: list[int] = []
        self.surface: Surface | None = None
        self.shapes_cache: ShapeCache | None = None

    @property
    def prefix(self) -> str:
        return f"perception/distractor_{self.index}_"

    def slot_names(self) -> list[str]:
        return [f"{self.prefix}{k}" for k in range(int(self.count[1]))]

    def extend(self, document: MjcfDocument) -> None:
        add_textures(document)
        cache = MeshCache()
        for k, path in enumerate(self.meshes):
            file = str(cache.mujoco_file(path))
            scale = fmt([self.mesh_scale] * 3)
            ET.SubElement(
                document.asset, "mesh", name=f"{self.prefix}mesh_{k}", file=file, scale=scale
            )
        for name in self.slot_names():
            ET.SubElement(document.asset, "material", name=name)
            body = ET.SubElement(
                document.worldbody, "body", name=name, mocap="true", pos="0 0 -100"
            )
            ET.SubElement(body, "geom", name=name, type="box", size="0.01 0.01 0.01",
                          material=name, rgba="0.5 0.5 0.5 1", contype="0", conaffinity="0",
                          group=str(HIDDEN_GROUP))  # fmt: skip

    def bind(self, world: World) -> None:
        model = world.model
        self.slots = [
            (model.body(n).id, model.geom(n).id, model.material(n).id) for n in self.slot_names()
        ]
        self.mesh_ids = [model.mesh(f"{self.prefix}mesh_{k}").id for k in range(len(self.meshes))]
        self.textures = texture_ids(model)
        self.shapes_cache = ShapeCache(model)
        if self.surface_name is not None:
            self.surface = Surface.of_body(world, self.surface_name, self.area)

    def labelled_slots(self) -> list[tuple[str, str]]:
        """(slot body name, class) of each slot, when they are labelled."""
        return [(n, self.label) for n in self.slot_names()] if self.label is not None else []

    def apply(self, state: FrameState, rng: np.random.Generator) -> None:
        model, data = state.model, state.data
        assert self.shapes_cache is not None
        count = int(rng.integers(int(self.count[0]), int(self.count[1]) + 1))
        taken = state.occupied.setdefault(self.surface.name, []) if self.surface else []
        for k, (body, geom, material) in enumerate(self.slots):
            shape = self.shapes[int(rng.integers(len(self.shapes)))]
            half = rng.uniform(*self.size, size=3) / 2
            red, green, blue = self.colours.draw(rng)
            textured = rng.random() < self.texture
            texture = self.textures[int(rng.integers(len(self.textures)))]
            angles = rng.uniform(-math.pi, math.pi, size=3)
            spot = rng.random(3)
            mesh = int(rng.integers(max(len(self.mesh_ids), 1)))
            if k >= count:
                continue  # stays hidden (the baseline's group)
            model.geom_type[geom] = _TYPES[shape]
            if shape == "mesh":
                model.geom_dataid[geom] = self.mesh_ids[mesh]
            else:
                model.geom_dataid[geom] = -1
                model.geom_size[geom] = {
                    "box": half, "ellipsoid": half, "sphere": (half[0], 0.0, 0.0),
                    "cylinder": (half[0], half[1], 0.0), "capsule": (half[0], half[1], 0.0),
                }[shape]  # fmt: skip
            model.mat_rgba[material] = (red, green, blue, 1.0)
            model.mat_texid[material, _RGB] = texture if textured else -1
            if self.surface is not None:
                turn = rotation_rpy(0.0, 0.0, math.radians(rng.uniform(*self.yaw)))
                extent = geom_extent(self.shapes_cache, geom)
                assert extent is not None
                where = self.surface.place(extent, turn, 0.005, taken, rng)
                if where is None:
                    continue
                rotation = self.surface.axes @ turn
            else:
                where = self.center + (spot - 0.5) * self.extent
                rotation = rotation_rpy(*angles)
            model.geom_group[geom] = 0
            set_body_pose(model, data, body, where, rotation)
