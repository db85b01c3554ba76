"""`type: lights`: how many lights shine, from where, in what colour and intensity, and
which cast shadows.

    - type: lights
      count: [1, 3]              # lights on: the scene's first, then extra slots (max 8)
      region: {center: [0, 0, 2], size: [2, 2, 1]}   # box (m) light positions are drawn in
      target: [0, 0, 0]          # lights aim here ...
      target_jitter: [0.3, 0.3, 0]  # ... give or take this much (m) per axis
      intensity: [0.3, 0.9]      # diffuse level of each light
      tint: [0.85, 1.0]          # each colour channel scaled by a draw from this range
      ambient: [0.0, 0.15]       # ambient level of each light
      shadows: 0.5               # probability that a light casts shadows
      directional: 0.3           # probability that a light is directional (else a spot)
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from simbridge.perception.randomizers.base import FrameState, Randomizer
from simbridge.perception.section import Range, Section
from simbridge.sim import World
from simbridge.sim.urdf.document import MjcfDocument

__all__ = ["LightsRandomizer"]

MAX_LIGHTS = 8
_DIRECTIONAL = int(mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
_SPOT = int(mujoco.mjtLightType.mjLIGHT_SPOT)


class LightsRandomizer(Randomizer):
    kind = "lights"
    KEYS = ("type", "count", "region", "target", "target_jitter", "intensity", "tint", "ambient",
            "shadows", "directional")  # fmt: skip

    def __init__(self, section: Section) -> None:
        self.count = section.range("count", (1.0, 3.0), 0.0, MAX_LIGHTS)
        if self.count != tuple(round(c) for c in self.count):
            raise section.error(f"count must be whole numbers, got {list(self.count)}", "count")
        region = section.sub("region")
        self.center = np.array(region.vector("center", 3, (0.0, 0.0, 2.0)))
        self.size = np.array(region.vector("size", 3, (2.0, 2.0, 1.0)))
        region.done(("center", "size"))
        self.target = np.array(section.vector("target", 3, (0.0, 0.0, 0.0)))
        self.jitter = np.array(section.vector("target_jitter", 3, (0.0, 0.0, 0.0)))
        self.intensity: Range = section.range("intensity", (0.3, 0.9), 0.0)
        self.tint: Range = section.range("tint", (0.85, 1.0), 0.0)
        self.ambient: Range = section.range("ambient", (0.0, 0.15), 0.0)
        self.shadows = section.number("shadows", 0.5, 0.0, 1.0)
        self.directional = section.number("directional", 0.3, 0.0, 1.0)
        section.done(self.KEYS)
        self.lights: list[int] = []

    def extend(self, document: MjcfDocument) -> None:
        have = len(document.worldbody.findall("light"))
        for index in range(have, int(self.count[1])):
            ET.SubElement(
                document.worldbody, "light", name=f"perception/light_{index}", active="false"
            )

    def bind(self, world: World) -> None:
        self.lights = list(range(world.model.nlight))

    def apply(self, state: FrameState, rng: np.random.Generator) -> None:
        model = state.model
        count = int(rng.integers(int(self.count[0]), int(self.count[1]) + 1))
        for slot, light in enumerate(self.lights):
            on = slot < count
            model.light_active[light] = on
            if not on:
                continue
            position = self.center + (rng.random(3) - 0.5) * self.size
            aim = self.target + (rng.random(3) - 0.5) * 2 * self.jitter - position
            norm = float(np.linalg.norm(aim))
            model.light_pos[light] = position
            model.light_dir[light] = aim / norm if norm > 1e-9 else (0.0, 0.0, -1.0)
            level = rng.uniform(*self.intensity)
            model.light_diffuse[light] = level * rng.uniform(*self.tint, size=3)
            model.light_ambient[light] = rng.uniform(*self.ambient)
            model.light_castshadow[light] = bool(rng.random() < self.shadows)
            model.light_type[light] = _DIRECTIONAL if rng.random() < self.directional else _SPOT
