"""Shared by the appearance randomisers: colours drawn in HSV, and the procedural texture
set (greyscale checkers, stripes, gradients and noise that a material's colour tints)."""

from __future__ import annotations

import colorsys
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import mujoco
import numpy as np

from simbridge.perception.section import Range, Section
from simbridge.sim.urdf.document import MjcfDocument

__all__ = ["TEXTURES", "ColourRanges", "add_textures", "texture_ids"]

TEXTURES: tuple[dict[str, str], ...] = (
    {"builtin": "checker", "rgb1": "1 1 1", "rgb2": "0.35 0.35 0.35", "width": "64"},
    {"builtin": "checker", "rgb1": "0.9 0.9 0.9", "rgb2": "0.6 0.6 0.6", "width": "16"},
    {"builtin": "gradient", "rgb1": "1 1 1", "rgb2": "0.2 0.2 0.2", "width": "64"},
    {"builtin": "flat", "rgb1": "0.85 0.85 0.85", "mark": "random", "markrgb": "0.3 0.3 0.3",
     "random": "0.25", "width": "128"},
    {"builtin": "flat", "rgb1": "1 1 1", "mark": "edge", "markrgb": "0.2 0.2 0.2", "width": "32"},
    {"builtin": "flat", "rgb1": "0.9 0.9 0.9", "mark": "cross", "markrgb": "0.4 0.4 0.4",
     "width": "64"},
    {"builtin": "flat", "rgb1": "0.8 0.8 0.8", "mark": "random", "markrgb": "1 1 1",
     "random": "0.6", "width": "64"},
    {"builtin": "checker", "rgb1": "1 1 1", "rgb2": "0.1 0.1 0.1", "width": "256"},
)  # fmt: skip
"""The procedural set: MuJoCo built-in textures, all grey so any colour can tint them."""
_PREFIX = "perception/texture_"


def add_textures(document: MjcfDocument) -> None:
    """Add the procedural set to the model once (later calls do nothing)."""
    asset = document.asset
    if asset.find(f"texture[@name='{_PREFIX}0']") is not None:
        return
    for index, attrs in enumerate(TEXTURES):
        attributes = {"name": f"{_PREFIX}{index}", "type": "2d", **attrs}
        attributes["height"] = attrs["width"]  # square
        ET.SubElement(asset, "texture", attributes)


def texture_ids(model: mujoco.MjModel) -> list[int]:
    """The procedural set's texture ids."""
    return [model.texture(f"{_PREFIX}{i}").id for i in range(len(TEXTURES))]


@dataclass(frozen=True)
class ColourRanges:
    """Colours drawn uniformly in HSV (each in [0, 1])."""

    hue: Range = (0.0, 1.0)
    saturation: Range = (0.2, 1.0)
    value: Range = (0.2, 1.0)

    KEYS = ("hue", "saturation", "value")

    @classmethod
    def parse(cls, section: Section) -> ColourRanges:
        return cls(
            section.range("hue", cls.hue, 0.0, 1.0),
            section.range("saturation", cls.saturation, 0.0, 1.0),
            section.range("value", cls.value, 0.0, 1.0),
        )

    def draw(self, rng: np.random.Generator) -> tuple[float, float, float]:
        h, s, v = (float(rng.uniform(*r)) for r in (self.hue, self.saturation, self.value))
        return colorsys.hsv_to_rgb(h, s, v)
