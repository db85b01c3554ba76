"""Randomisers of the rendered RGB image (labels stay as rendered):

- type: background           # where no geometry was drawn (the sky), a procedural image
  probability: 1.0           # share of images that get one
  kinds: [gradient, checker, noise, flat]
  hue: [0, 1]                # its colours, as for `materials`
  saturation: [0, 0.6]
  value: [0.3, 1]

- type: noise
  gaussian: [0, 6]           # standard deviation of added noise, in 8-bit levels
  blur: [0, 1.0]             # Gaussian blur sigma in pixels (0: none)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from PIL import Image, ImageFilter

from simbridge.perception.randomizers.appearance import ColourRanges
from simbridge.perception.randomizers.base import Randomizer
from simbridge.perception.section import Range, Section

__all__ = ["BACKGROUNDS", "BackgroundRandomizer", "NoiseRandomizer"]

BACKGROUNDS = ("gradient", "checker", "noise", "flat")


class BackgroundRandomizer(Randomizer):
    kind = "background"
    image_step = True
    KEYS = ("type", "probability", "kinds", *ColourRanges.KEYS)

    def __init__(self, section: Section) -> None:
        self.probability = section.number("probability", 1.0, 0.0, 1.0)
        self.kinds = section.strings("kinds", BACKGROUNDS)
        for kind in self.kinds:
            if kind not in BACKGROUNDS:
                raise section.error(
                    f"unknown background {kind!r} (valid: {', '.join(BACKGROUNDS)})", "kinds"
                )
        self.colours = ColourRanges.parse(section)
        section.done(self.KEYS)

    @property
    def needs_segmentation(self) -> bool:
        return True

    def _image(self, height: int, width: int, rng: np.random.Generator) -> NDArray[np.float32]:
        first = np.array(self.colours.draw(rng), dtype=np.float32)
        second = np.array(self.colours.draw(rng), dtype=np.float32)
        kind = self.kinds[int(rng.integers(len(self.kinds)))]
        cell = int(rng.integers(8, 64))
        if kind == "gradient":
            t = np.linspace(0.0, 1.0, height, dtype=np.float32)[:, None, None]
            return np.broadcast_to(first * (1 - t) + second * t, (height, width, 3))
        if kind == "checker":
            rows = (np.arange(height) // cell)[:, None]
            cols = (np.arange(width) // cell)[None, :]
            return np.where(((rows + cols) % 2 == 0)[..., None], first, second)
        if kind == "noise":
            small = rng.random((height // cell + 1, width // cell + 1, 1), dtype=np.float32)
            big = np.repeat(np.repeat(small, cell, axis=0), cell, axis=1)[:height, :width]
            return first * (1 - big) + second * big
        return np.broadcast_to(first, (height, width, 3))

    def post(
        self,
        rgb: NDArray[np.uint8],
        segmentation: NDArray[np.int32] | None,
        rng: np.random.Generator,
    ) -> NDArray[np.uint8]:
        apply = rng.random() < self.probability
        image = self._image(rgb.shape[0], rgb.shape[1], rng)
        if not apply or segmentation is None:
            return rgb
        empty = segmentation[..., 0] < 0
        out = rgb.copy()
        out[empty] = (image[empty] * 255.0 + 0.5).astype(np.uint8)
        return out


class NoiseRandomizer(Randomizer):
    kind = "noise"
    image_step = True
    KEYS = ("type", "gaussian", "blur")

    def __init__(self, section: Section) -> None:
        self.gaussian: Range = section.range("gaussian", (0.0, 6.0), 0.0)
        self.blur: Range = section.range("blur", (0.0, 1.0), 0.0)
        section.done(self.KEYS)

    def post(
        self,
        rgb: NDArray[np.uint8],
        segmentation: NDArray[np.int32] | None,
        rng: np.random.Generator,
    ) -> NDArray[np.uint8]:
        sigma = rng.uniform(*self.gaussian)
        radius = rng.uniform(*self.blur)
        out = rgb
        if radius > 0:
            out = np.asarray(Image.fromarray(out).filter(ImageFilter.GaussianBlur(radius)))
        if sigma > 0:
            noise = rng.standard_normal(out.shape, dtype=np.float32) * np.float32(sigma)
            out = np.clip(out.astype(np.float32) + noise + 0.5, 0, 255).astype(np.uint8)
        return out
