"""`type: materials`: the colour, texture and shine of chosen bodies' geoms.

    - type: materials
      bodies: [cube*, table, floor]   # body names or glob patterns (scene objects are bodies)
      hue: [0, 1]                # colour drawn in HSV, each in [0, 1]
      saturation: [0.2, 1]
      value: [0.2, 1]
      texture: 0.5               # probability of a texture from the procedural set
      texture_repeat: [1, 6]     # texture repeats across a face
      specular: [0, 0.6]         # the classic renderer's material terms, each in [0, 1]
      shininess: [0, 1]
      reflectance: [0, 0]        # mirror reflection (drawn only on planes and box tops)

Each matched geom gets a material of its own, so geoms change independently.
"""

from __future__ import annotations

import fnmatch
import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from simbridge.errors import PerceptionError
from simbridge.perception.randomizers.appearance import ColourRanges, add_textures, texture_ids
from simbridge.perception.randomizers.base import FrameState, Randomizer
from simbridge.perception.section import Range, Section
from simbridge.sim import World
from simbridge.sim.urdf.document import MjcfDocument

__all__ = ["MaterialsRandomizer", "matching_bodies"]

_RGB = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
_DEFAULT_RGBA = np.array([0.5, 0.5, 0.5, 1.0], dtype=np.float32)
"""A geom with this rgba shows its material's colour (MuJoCo's rule)."""


def matching_bodies(model: mujoco.MjModel, patterns: tuple[str, ...], who: str) -> list[int]:
    """Body ids whose names match any of `patterns` (an error names the bodies if none)."""
    names = [model.body(b).name for b in range(model.nbody)]
    found = [b for b, n in enumerate(names) if any(fnmatch.fnmatchcase(n, p) for p in patterns)]
    if not found:
        raise PerceptionError(
            f"{who}: no body matches {list(patterns)} (bodies: {', '.join(names[1:])})"
        )
    return found


class MaterialsRandomizer(Randomizer):
    kind = "materials"
    KEYS = ("type", "bodies", "texture", "texture_repeat", "specular", "shininess",
            "reflectance", *ColourRanges.KEYS)  # fmt: skip

    def __init__(self, section: Section, index: int) -> None:
        self.name = "bodies"
        self.patterns = section.strings("bodies")
        if not self.patterns:
            raise section.error("missing key 'bodies' (body names or glob patterns)")
        self.colours = ColourRanges.parse(section)
        self.texture = section.number("texture", 0.5, 0.0, 1.0)
        self.repeat: Range = section.range("texture_repeat", (1.0, 6.0), 0.01)
        self.specular: Range = section.range("specular", (0.0, 0.6), 0.0, 1.0)
        self.shininess: Range = section.range("shininess", (0.0, 1.0), 0.0, 1.0)
        self.reflectance: Range = section.range("reflectance", (0.0, 0.0), 0.0, 1.0)
        section.done(self.KEYS)
        self.prefix = f"perception/material_{index}_"
        self.geoms: list[int] = []
        self.materials: list[int] = []
        self.textures: list[int] = []

    def _document_geoms(self, document: MjcfDocument) -> int:
        count = 0
        for body in document.worldbody.iter("body"):
            name = body.get("name", "")
            if any(fnmatch.fnmatchcase(name, p) for p in self.patterns):
                count += sum(1 for g in body.findall("geom") if g.get("group", "0") != "3")
        return count

    def extend(self, document: MjcfDocument) -> None:
        add_textures(document)
        for slot in range(self._document_geoms(document)):
            ET.SubElement(document.asset, "material", name=f"{self.prefix}{slot}")

    def bind(self, world: World) -> None:
        model = world.model
        bodies = set(matching_bodies(model, self.patterns, self.name))
        self.geoms = [
            g
            for g in range(model.ngeom)
            if int(model.geom_bodyid[g]) in bodies and model.geom_group[g] < 3
        ]
        self.materials = []
        for slot in range(len(self.geoms)):
            self.materials.append(model.material(f"{self.prefix}{slot}").id)
        self.textures = texture_ids(model)

    def apply(self, state: FrameState, rng: np.random.Generator) -> None:
        model = state.model
        for geom, material in zip(self.geoms, self.materials, strict=True):
            red, green, blue = self.colours.draw(rng)
            textured = rng.random() < self.texture
            texture = int(rng.integers(len(self.textures)))
            repeat = rng.uniform(*self.repeat)
            model.geom_matid[geom] = material
            model.geom_rgba[geom] = _DEFAULT_RGBA
            model.mat_rgba[material] = (red, green, blue, 1.0)
            model.mat_texid[material, _RGB] = self.textures[texture] if textured else -1
            model.mat_texrepeat[material] = (repeat, repeat)
            model.mat_specular[material] = rng.uniform(*self.specular)
            model.mat_shininess[material] = rng.uniform(*self.shininess)
            model.mat_reflectance[material] = rng.uniform(*self.reflectance)
